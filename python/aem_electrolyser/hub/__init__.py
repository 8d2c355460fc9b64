"""The hub FMU driven from Python through fmpy: `HubFMU` steps it by name (the examples, mosaik
and HELICS), `HubRunner` runs it through a test signal fast (the reserve prequalification)."""

from .driver import HubFMU
from .runner import Hub, HubRunner

__all__ = ["HubFMU", "Hub", "HubRunner"]
