"""The reserve products a hub can offer: the FMU parameters that offer each, the test
programme it must pass, and how far the operating window lets it go.

Direction, for a load: up = draw less (under-frequency), down = draw more, both = symmetric.
Static FCR-D is not assessed: it presumes a relay-style activation that waits 60 s in the
normal band before a slow deactivation (at most 2.5 %/s), which the FMU's linear FCR-D
characteristic does not implement (the evaluators for it exist in `evaluate.static_fcr_d`).
"""

from dataclasses import dataclass, field
from typing import Callable, Optional

from . import signals
from .signals import BOTH, DOWN, UP


@dataclass(frozen=True)
class Product:
    """A product: its name, the FMU parameters that offer capacity C [W] (None: aFRR/mFRR,
    driven through powerReference), its time-domain tests, its sine-test family (or None),
    its direction, whether reduction factors may lower the capacity, and fixed parameters."""

    name: str
    capacity_parameter: Optional[str]
    tests: Callable[[float], list]
    sine: Optional[str]
    direction: int
    use_reduction: bool = False
    parameters: dict = field(default_factory=dict)


def _ffr(trigger):
    return Product(
        f"FFR {trigger} Hz",
        "ffrCapacity",
        lambda dt: [signals.ffr_step(trigger, dt)],
        None,
        UP,
        parameters={"ffrTriggerFrequency": trigger, "ffrSupportDuration": 30.0},
    )


PRODUCTS = [
    Product("FCR-D up", "fcrDUpCapacity", lambda dt: [signals.fcr_d_ramp(UP, dt)], "FCR-D up", UP, True),
    Product("FCR-D down", "fcrDDownCapacity", lambda dt: [signals.fcr_d_ramp(DOWN, dt)], "FCR-D down", DOWN, True),
    Product("FCR-N", "fcrNCapacity", lambda dt: [signals.fcr_n_steps(dt)], "FCR-N", BOTH, True),
    _ffr(49.7),
    _ffr(49.6),
    _ffr(49.5),
    Product("Continental FCR", "fcrCapacity", lambda dt: [signals.ce_fcr_steps(dt)], None, BOTH),
    Product("aFRR up", None, lambda dt: [signals.frr_step("aFRR", UP, dt)], None, UP),
    Product("aFRR down", None, lambda dt: [signals.frr_step("aFRR", DOWN, dt)], None, DOWN),
    Product("mFRR up", None, lambda dt: [signals.frr_step("mFRR", UP, dt)], None, UP),
    Product("mFRR down", None, lambda dt: [signals.frr_step("mFRR", DOWN, dt)], None, DOWN),
]
BY_NAME = {p.name: p for p in PRODUCTS}


def window_bound(product: Product, baseline: float, least: float, most: float) -> float:
    """The largest capacity [W] the operating window allows at `baseline` [W] in the product's
    direction(s), with the hub's least and most steady power [W]."""
    down_room, up_room = baseline - least, most - baseline
    return {UP: down_room, DOWN: up_room, BOTH: min(down_room, up_room)}[product.direction]
