"""The largest capacity that passes, by bisection over the offered capacity C [W].

Assumption (monotonicity): if capacity C passes every pass/fail requirement then every smaller
C > 0 passes too (a bigger offer asks more of the same unit). Bisection then converges to the
boundary; if the assumption is false it still returns a passing capacity, not necessarily the
largest. UNSURE requirements never decide (informative). With `use_reduction`, a failing
requirement whose largest passing reduction factor K_red is in its range counts as passing
(the sellable capacity is then min K_red · C, reported as `reduced_capacity`; `sellable` is
the capacity every report states). An upper bound ≤ 0 (the operating window allows nothing in
this direction at this baseline) runs nothing and gives capacity 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Optional

from .requirement import FAIL, Requirement


@dataclass
class CapacityResult:
    """capacity [W] tested and passing (0 if none passes; before any reduction), its fraction
    of the rated power, the limiting requirements (those failing just above: at capacity +
    tolerance, or at the upper bound), the evaluations at the result and just above, every
    (C, passed) tried, the upper bound searched [W] and the capacity of the evaluation just
    above [W] (None if the upper bound passes or nothing was run)."""

    capacity: float
    rated_power: float
    limiting: list
    at_capacity: list
    above: list
    reduced_capacity: Optional[float] = None
    history: list = field(default_factory=list)
    upper_bound_passes: bool = False
    upper: Optional[float] = None
    above_capacity: Optional[float] = None

    @property
    def percent_of_rated(self) -> float:
        return 100.0 * self.capacity / self.rated_power

    @property
    def sellable(self) -> float:
        """The capacity to sell [W]: the passing capacity times the reduction factor where the
        rules allow one (else the passing capacity itself)."""
        return self.capacity if self.reduced_capacity is None else self.reduced_capacity

    @property
    def reduction_factor(self) -> Optional[float]:
        """sellable / capacity when a reduction factor applies (< 1), else None."""
        if self.reduced_capacity is None or self.capacity <= 0 or self.reduced_capacity >= self.capacity:
            return None
        return self.reduced_capacity / self.capacity

    @property
    def window_empty(self) -> bool:
        """The operating window allows no capacity (upper bound ≤ 0): nothing was tested."""
        return self.upper is not None and self.upper <= 0


def failing(results, use_reduction: bool = False) -> list:
    """The requirements that decide a failure."""
    return [r for r in results if r.status == FAIL and not (use_reduction and r.k_red)]


def reduction(results) -> float:
    """min K_red over the failing requirements that have one (1 if none fail)."""
    ks = [r.k_red for r in results if r.status == FAIL and r.k_red]
    return min(ks) if ks else 1.0


def largest_capacity(
    run: Callable[[float], object],
    evaluate: Callable[[object, float], list],
    upper: float,
    rated_power: float,
    tolerance: Optional[float] = None,
    use_reduction: bool = False,
) -> CapacityResult:
    """Bisection on (0, upper] [W]: run(C) -> trace, evaluate(trace, C) -> Requirements.
    Stops when the bracket is ≤ tolerance (default 0.5 % of rated_power) [W]; C = 0 is never
    run (taken as passing)."""
    tol = 0.005 * rated_power if tolerance is None else tolerance  # also in most_steps
    history = []
    if upper <= 0:
        return CapacityResult(0.0, rated_power, [], [], [], None, history, False, upper)

    def attempt(c):
        res = evaluate(run(c), c)
        ok = not failing(res, use_reduction)
        history.append((c, ok))
        return ok, res

    ok, res_hi = attempt(upper)
    if ok:
        red = upper * reduction(res_hi) if use_reduction else None
        return CapacityResult(upper, rated_power, [], res_hi, [], red, history, True, upper)
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
    return CapacityResult(lo, rated_power, limiting, res_lo, res_hi, red, history, False, upper, hi)


def most_steps(upper: float, rated_power: float, tolerance: Optional[float] = None) -> int:
    """The most capacities largest_capacity tries on (0, upper] (the upper bound, then halvings
    until the bracket is ≤ tolerance); 0 if upper ≤ 0."""
    tol = 0.005 * rated_power if tolerance is None else tolerance
    if upper <= 0:
        return 0
    return 1 + max(0, math.ceil(math.log2(upper / tol) - 1e-12))


def limiting_names(result: CapacityResult) -> list:
    return [r.name for r in result.limiting]


__all__ = ["CapacityResult", "largest_capacity", "failing", "reduction", "most_steps", "limiting_names", "Requirement"]
