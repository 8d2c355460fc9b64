"""The dispatch that sells the most of a product at a base power: how many of the hub's
modules run (each at the base power's equal share; the others idle at the start, a cold start
away, and in warm standby once stopped), for the largest prequalified capacity.

At base power B a hub of N modules can run any count n with every running module inside its
window, P(m)·n ≤ B ≤ P(M)·n: n from ⌈B/P(M)⌉ (sequential dispatch) to min(N, ⌊B/P(m)⌋) (the most
modules; equal dispatch where that is all N). The count decides what the hub can move: a
decrease down to n·P(m), an increase up to n·P(M) and at n times one module's rising-current
ramp. The FMU runs a chosen count as target dispatch with dispatchTargetSetpoint = u(B/n), the
setpoint at which one module draws B/n (its count then follows the base power and an
activation is shared by the running modules).

The search: every feasible count where there are at most `EXHAUSTIVE` of them; otherwise the
bracket search of aem_electrolyser.reserves.optimise over the count (a grid, ends included,
then a bracket shrunk by thirds), each count assessed once. Deterministic: no random draw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

from aem_electrolyser.reserves import optimise

#: Up to this many feasible counts, every one is assessed.
EXHAUSTIVE = 12


@dataclass(frozen=True)
class ModuleCurve:
    """A running module's steady power P(u) = (V0 + R·K·u)·K·u [W] at setpoint u [%], and its
    window [minSetpoint, maxSetpoint] [%]."""

    gain: float
    voltage_intercept: float
    ohmic_resistance: float
    min_setpoint: float
    max_setpoint: float

    def power(self, u: float) -> float:
        i = self.gain * u
        return (self.voltage_intercept + self.ohmic_resistance * i) * i

    def setpoint(self, power: float) -> float:
        """The setpoint [%] at which the module draws `power` [W] (the positive root,
        cancellation-free): u = 2P / (K·(V0 + √(V0² + 4RP)))."""
        v0, r = self.voltage_intercept, self.ohmic_resistance
        return 2.0 * power / (self.gain * (v0 + math.sqrt(v0 * v0 + 4.0 * r * power)))


def feasible_counts(n_modules: int, base: float, curve: ModuleCurve) -> range:
    """The running counts that hold base power `base` [W] with every running module inside its
    window (empty if none can)."""
    low = math.ceil(base / curve.power(curve.max_setpoint) - 1e-12)
    high = min(n_modules, math.floor(base / curve.power(curve.min_setpoint) + 1e-12))
    return range(max(low, 1), high + 1)


def target_setpoint(count: int, base: float, curve: ModuleCurve) -> float:
    """dispatchTargetSetpoint [%] that makes target dispatch run `count` modules at `base` [W],
    held inside the window against rounding."""
    u = curve.setpoint(base / count)
    return min(max(u, curve.min_setpoint), curve.max_setpoint)


@dataclass(frozen=True)
class Found:
    """The best count and every count tried, as (count, capacity [W]) in the order tried."""

    count: int
    capacity: float
    tried: tuple

    def table(self) -> list:
        return sorted(self.tried)


def search(
    capacities: Callable[[Sequence[int]], Sequence[float]], counts: range, exhaustive: int = EXHAUSTIVE
) -> Found:
    """The count in `counts` with the largest capacity; `capacities(counts)` assesses several
    at once (in parallel if it likes). Ties go to the fewest running modules (the least
    standby and start-up energy)."""
    if len(counts) == 0:
        raise ValueError("no running count holds this base power inside the window")
    known: dict = {}

    def assess(ns):
        new = [n for n in dict.fromkeys(ns) if n not in known]
        if new:
            for n, c in zip(new, capacities(new)):
                known[n] = float(c)
        return [known[n] for n in ns]

    if len(counts) <= exhaustive:
        assess(list(counts))
    else:
        optimise.search(
            lambda xs: assess([round(x) for x in xs]),
            float(counts[0]),
            float(counts[-1]),
        )
    best = max(sorted(known), key=lambda n: known[n])
    return Found(best, known[best], tuple(known.items()))


__all__ = ["EXHAUSTIVE", "Found", "ModuleCurve", "feasible_counts", "search", "target_setpoint"]
