"""Durations and powers written with their unit in a study file ("365 d", "64 MW")."""

import re

SECONDS = {"s": 1.0, "min": 60.0, "h": 3600.0, "d": 86400.0}
WATTS = {"W": 1.0, "kW": 1e3, "MW": 1e6, "GW": 1e9}


def quantity(value, units, what):
    """A number with one of `units` (name -> factor to SI) as SI; a bare number is SI already."""
    if isinstance(value, bool):
        raise ValueError(f"{what}: {value!r} is not a quantity")
    if isinstance(value, (int, float)):
        return float(value)
    match = re.fullmatch(r"\s*([-+0-9.eE]+)\s*([A-Za-z]+)\s*", str(value))
    if not match or match.group(2) not in units:
        raise ValueError(f"{what}: {value!r} is not a number with a unit of {', '.join(units)}")
    return float(match.group(1)) * units[match.group(2)]


def duration(value, what):
    """Seconds [s] of "8760 h", "365 d", "1 s" or a number of seconds."""
    return quantity(value, SECONDS, what)


def power(value, what):
    """Watts [W] of "64 MW" or a number of watts."""
    return quantity(value, WATTS, what)
