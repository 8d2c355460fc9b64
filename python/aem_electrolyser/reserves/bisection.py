"""The largest capacity that passes, by bisection over the offered capacity C [W].

Assumption (monotonicity): if capacity C passes every pass/fail requirement then every smaller
C > 0 passes too (a bigger offer asks more of the same unit). Bisection then converges to the
boundary; if the assumption is false it still returns a passing capacity, not necessarily the
largest. UNSURE requirements never decide (informative). With `use_reduction`, a failing
requirement whose largest passing reduction factor K_red is in its range counts as passing
(the sellable capacity is then min K_red · C, reported as `reduced_capacity`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional

from .requirement import FAIL, Requirement


@dataclass
class CapacityResult:
    """capacity [W] (0 if none passes), its fraction of the rated power, the limiting
    requirements (those failing just above: at capacity + tolerance, or at the upper bound),
    the evaluations at the result and just above, and every (C, passed) tried."""

    capacity: float
    rated_power: float
    limiting: list
    at_capacity: list
    above: list
    reduced_capacity: Optional[float] = None
    history: list = field(default_factory=list)
    upper_bound_passes: bool = False

    @property
    def percent_of_rated(self) -> float:
        return 100.0 * self.capacity / self.rated_power


def failing(results, use_reduction: bool = False) -> list:
    """The requirements that decide a failure."""
    return [r for r in results if r.status == FAIL and not (use_reduction and r.k_red)]


def reduction(results) -> float:
    """min K_red over the failing requirements that have one (1 if none fail)."""
    ks = [r.k_red for r in results if r.status == FAIL and r.k_red]
    return min(ks) if ks else 1.0


def largest_capacity(run: Callable[[float], object],
                     evaluate: Callable[[object, float], list],
                     upper: float, rated_power: float, tolerance: Optional[float] = None,
                     use_reduction: bool = False) -> CapacityResult:
    """Bisection on (0, upper] [W]: run(C) -> trace, evaluate(trace, C) -> Requirements.
    Stops when the bracket is ≤ tolerance (default 0.5 % of rated_power) [W]; C = 0 is never
    run (taken as passing)."""
    tol = 0.005 * rated_power if tolerance is None else tolerance
    history = []

    def attempt(c):
        res = evaluate(run(c), c)
        ok = not failing(res, use_reduction)
        history.append((c, ok))
        return ok, res

    ok, res_hi = attempt(upper)
    if ok:
        red = upper * reduction(res_hi) if use_reduction else None
        return CapacityResult(upper, rated_power, [], res_hi, [], red, history, True)
    lo, hi, res_lo = 0.0, upper, []
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        ok, res = attempt(mid)
        if ok:
            lo, res_lo = mid, res
        else:
            hi, res_hi = mid, res
    limiting = failing(res_hi, use_reduction)
    red = lo * reduction(res_lo) if (use_reduction and res_lo) else None
    return CapacityResult(lo, rated_power, limiting, res_lo, res_hi, red, history)


def limiting_names(result: CapacityResult) -> list:
    return [r.name for r in result.limiting]


__all__ = ["CapacityResult", "largest_capacity", "failing", "reduction", "limiting_names",
           "Requirement"]
