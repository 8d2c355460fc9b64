"""The reserve control that sells the most of a product: where to put the zero τn of the
pre-filtered transfer function K(τn s + 1)/((τp1 s + 1)(τp2 s + 1)) (the FMU's
`reserveFilterZero`), within [τp1, τp2], for the largest prequalified capacity.

The capacity as a function of τn is what the test programme makes of it: piecewise constant
(the bisection's resolution), rising where a faster response helps (the ramp and step tests),
falling where it hurts (the sine tests' stability margin). The search is deterministic: a
grid, logarithmic in τn, that always holds the family's two known members (plain droop at τz,
the slow pole cancelled at τp2), then a bracket around the best grid point shrunk by thirds
(two candidates per round, evaluated together) for a fixed number of rounds. No random draw,
so the same inputs give the same answer; the number of evaluations is fixed in advance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

#: Grid points over [τp1, τp2] before refining, and the bracket's refining rounds (two
#: evaluations each).
GRID = 7
ROUNDS = 5


@dataclass(frozen=True)
class Candidate:
    """One control tried: its zero τn [s] and the capacity it sells [W]."""

    zero: float
    capacity: float


@dataclass
class Search:
    """The best control found and every one tried (in the order tried, each once)."""

    best: Candidate
    tried: list = field(default_factory=list)

    def table(self) -> list:
        """(τn [s], capacity [W]) of every control tried, by τn."""
        return sorted((c.zero, c.capacity) for c in self.tried)


def grid(lo: float, hi: float, n: int = GRID, known: Iterable[float] = ()) -> list:
    """n zeros log-spaced over [lo, hi] [s], ends included, with the `known` ones inside it."""
    if not (0.0 < lo <= hi and math.isfinite(hi)):
        raise ValueError(f"the zero's range must be 0 < lo <= hi, not [{lo}, {hi}]")
    if lo == hi:
        return [lo]
    points = {lo * (hi / lo) ** (k / (n - 1)) for k in range(n)} | {lo, hi}
    points |= {z for z in known if lo <= z <= hi}
    return sorted(points)


def search(
    capacities: Callable[[Sequence[float]], Sequence[float]],
    lo: float,
    hi: float,
    known: Iterable[float] = (),
    n_grid: int = GRID,
    rounds: int = ROUNDS,
) -> Search:
    """The zero in [lo, hi] [s] with the largest capacity. `capacities(zeros)` gives the
    capacity [W] of each zero (the caller may evaluate them in parallel). Ties go to the
    candidate tried first, the grid in ascending order, so the answer is reproducible."""
    tried: list[Candidate] = []
    known_capacity: dict = {}

    def evaluate(zeros):
        """Each zero's candidate, asking `capacities` only for zeros not tried before."""
        new = [z for z in dict.fromkeys(zeros) if z not in known_capacity]
        if new:
            for z, c in zip(new, capacities(new)):
                known_capacity[z] = float(c)
                tried.append(Candidate(z, float(c)))
        return [Candidate(z, known_capacity[z]) for z in zeros]

    points = evaluate(grid(lo, hi, n_grid, known))
    best = max(points, key=lambda c: c.capacity)
    i = points.index(best)
    left = points[max(i - 1, 0)].zero
    right = points[min(i + 1, len(points) - 1)].zero
    for _ in range(rounds):
        if right <= left:
            break
        # Thirds of the bracket in log τn.
        a, b = math.log(left), math.log(right)
        inner = [math.exp(a + (b - a) / 3.0), math.exp(a + 2.0 * (b - a) / 3.0)]
        one, two = evaluate(inner)
        for c in (one, two):
            if c.capacity > best.capacity:
                best = c
        # Keep the two thirds around the better inner point (ties: the left one).
        if two.capacity > one.capacity:
            left = one.zero
        else:
            right = two.zero
        if not (left <= best.zero <= right):
            # The best stays inside the bracket: a grid point may beat both inner ones.
            left, right = min(left, best.zero), max(right, best.zero)
    return Search(best, tried)


def margin(requirement) -> float:
    """How far a requirement's measured value lies inside its limits, relative to the nearest
    limit's magnitude (negative: outside); infinite without a limit."""
    gaps = []
    if requirement.low is not None:
        gaps.append((requirement.measured - requirement.low) / max(abs(requirement.low), 1e-12))
    if requirement.high is not None:
        gaps.append((requirement.high - requirement.measured) / max(abs(requirement.high), 1e-12))
    return min(gaps) if gaps else math.inf


__all__ = ["Candidate", "Search", "grid", "search", "margin", "GRID", "ROUNDS"]
