"""The reserve control that sells the most of a product: where to put the zero τn of the
pre-filtered transfer function K(τn s + 1)/((τp1 s + 1)(τp2 s + 1)) (the FMU's
`reserveFilterZero`), within [τp1, τp2], for the largest prequalified capacity.

The capacity as a function of τn is what the test programme makes of it, and it is not smooth:
piecewise constant (the bisection's resolution), with bands where it passes between zeros where
nothing passes (FCR-N: the steady state fails on one side, the stability margin on the other),
cliffs, and stretches where the reduction factor sits at its floor. A search that assumes one
hump misses bands. So the search scans: zeros log-spaced over [τp1, τp2] with neighbours at
most RESOLUTION apart (a ratio), which puts at least one scan point inside every band wider
than the resolution (wider in the ratio of its ends), the family's two known members (plain
droop at τz, the slow pole cancelled at τp2) included; then around each of the best PEAKS
local maxima of the scan a bracket (its two neighbours) is shrunk by thirds (two candidates
per round, all brackets' candidates evaluated together) for ROUNDS rounds. Deterministic: no
random draw, the number of zeros tried is fixed in advance by the range and the resolution.

A full evaluation of a zero is a bisection over the capacity; most zeros of a scan cannot beat
the best found before them, which one test at that capacity shows. Given that test (`beats`),
the scan is a branch and bound: the known zeros first, then the scan in batches from coarse to
fine (a good best early), each zero searched in full only where it passes just above the best
so far.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterable, Optional, Sequence

#: Neighbouring scan points differ by at most this ratio: every band of passing zeros [a, b]
#: with b/a ≥ RESOLUTION holds one (5 %: over the paper's [1.995, 113.568] s, 84 zeros).
RESOLUTION = 1.05
#: The local maxima of the scan refined, and each bracket's refining rounds (two evaluations
#: each).
PEAKS = 3
ROUNDS = 5


@dataclass(frozen=True)
class Candidate:
    """One control tried: its zero τn [s] and the capacity it sells [W]; with `bound`, the
    capacity is only known not to exceed this (the zero failed just above the best so far)."""

    zero: float
    capacity: float
    bound: bool = False


@dataclass
class Search:
    """The best control found and every one tried (in the order tried, each once), and the
    scan's resolution (the ratio of neighbouring scan points)."""

    best: Candidate
    tried: list = field(default_factory=list)
    resolution: float = RESOLUTION

    def table(self) -> list:
        """(τn [s], capacity [W], whether only a bound) of every control tried, by τn."""
        return sorted((c.zero, c.capacity, c.bound) for c in self.tried)


def grid(lo: float, hi: float, resolution: float = RESOLUTION, known: Iterable[float] = ()) -> list:
    """Zeros log-spaced over [lo, hi] [s], ends included, neighbours at most `resolution` apart
    (a ratio > 1), with the `known` ones inside it."""
    if not (0.0 < lo <= hi and math.isfinite(hi)):
        raise ValueError(f"the zero's range must be 0 < lo <= hi, not [{lo}, {hi}]")
    if not resolution > 1.0:
        raise ValueError(f"the scan's resolution is a ratio > 1, not {resolution}")
    if lo == hi:
        return [lo]
    n = max(2, math.ceil(math.log(hi / lo) / math.log(resolution) - 1e-9) + 1)
    points = {lo * (hi / lo) ** (k / (n - 1)) for k in range(n)} | {lo, hi}
    points |= {z for z in known if lo <= z <= hi}
    return sorted(points)


def peaks(points: Sequence[Candidate], count: int = PEAKS) -> list:
    """The indices of the `count` best local maxima of a scan (a plateau counts once, by its
    first point; a bound counts as less than any capacity known), best first, ties by
    position; only maxima that sell something, or the first point when nothing does."""
    caps = [-1.0 if c.bound else c.capacity for c in points]
    found = []
    i = 0
    while i < len(caps):
        j = i
        while j + 1 < len(caps) and caps[j + 1] == caps[i]:
            j += 1
        left = caps[i - 1] if i > 0 else -math.inf
        right = caps[j + 1] if j + 1 < len(caps) else -math.inf
        if caps[i] > left and caps[i] > right and caps[i] > 0:
            found.append(i)
        i = j + 1
    found.sort(key=lambda k: (-caps[k], k))
    return found[:count] or [0]


def coarse_to_fine(points: Sequence[float]) -> list:
    """The points in the order of a refining grid: the ends and every 2^k-th point first, then
    the points halfway between, and so on (each once)."""
    n = len(points)

    def level(i):
        if i in (0, n - 1):
            return math.inf
        return (i & -i).bit_length()

    return [points[i] for i in sorted(range(n), key=lambda i: (-level(i), i))]


#: Zeros asked for at once while scanning with a bound (the best so far is updated between
#: batches: larger batches keep workers busy, smaller ones prune more).
BATCH = 8


def search(
    capacities: Callable[[Sequence[float]], Sequence[float]],
    lo: float,
    hi: float,
    known: Iterable[float] = (),
    resolution: float = RESOLUTION,
    rounds: int = ROUNDS,
    count: int = PEAKS,
    beats: Optional[Callable[[Sequence[float], float], Sequence[bool]]] = None,
) -> Search:
    """The zero in [lo, hi] [s] with the largest capacity. `capacities(zeros)` gives the
    capacity [W] of each zero (the caller may evaluate them in parallel). Ties go to the
    candidate tried first (the known zeros, then the scan: in ascending order, or with `beats`
    from coarse to fine), so the answer is reproducible.

    With `beats(zeros, capacity)`, whether each zero could sell more than `capacity` [W] (it
    passes a little above it), the scan is a branch and bound: a zero that cannot beat the
    best so far is not searched in full (its candidate is a bound); under the bisection's own
    assumption (a capacity that passes means every smaller one passes) the best is the same as
    the full scan's, at a fraction of the cost."""
    tried: list[Candidate] = []
    known_capacity: dict = {}
    best_so_far = [0.0]

    def full(zeros):
        new = [z for z in dict.fromkeys(zeros) if z not in known_capacity or known_capacity[z].bound]
        if new:
            for z, c in zip(new, capacities(new)):
                candidate = Candidate(z, float(c))
                if z in known_capacity:
                    tried.remove(known_capacity[z])
                known_capacity[z] = candidate
                tried.append(candidate)
                best_so_far[0] = max(best_so_far[0], candidate.capacity)

    def evaluate(zeros):
        """Each zero's candidate, asking only for zeros not tried before (with `beats`, in
        full only those that beat the best so far)."""
        zeros = list(zeros)
        if beats is None:
            full(zeros)
        else:
            new = [z for z in dict.fromkeys(zeros) if z not in known_capacity]
            for k in range(0, len(new), BATCH):
                batch = new[k : k + BATCH]
                floor = best_so_far[0]
                if floor <= 0:
                    full(batch)
                    continue
                better = beats(batch, floor)
                for z, b in zip(batch, better):
                    if not b:
                        candidate = Candidate(z, floor, True)
                        known_capacity[z] = candidate
                        tried.append(candidate)
                full([z for z, b in zip(batch, better) if b])
        return [known_capacity[z] for z in zeros]

    order = sorted(z for z in set(known) if lo <= z <= hi)
    evaluate(order)
    scan = grid(lo, hi, resolution, known)
    if beats is not None:
        evaluate(coarse_to_fine(scan))  # a good best early prunes the rest
    points = evaluate(scan)
    best = max(points, key=lambda c: -1.0 if c.bound else c.capacity)
    brackets = []
    for i in peaks(points, count):
        left = points[max(i - 1, 0)].zero
        right = points[min(i + 1, len(points) - 1)].zero
        brackets.append([left, right, points[i]])
    value = lambda c: -1.0 if c.bound else c.capacity  # noqa: E731
    for _ in range(rounds):
        live = [b for b in brackets if b[1] > b[0]]
        if not live:
            break
        inner = []
        for left, right, _ in live:
            a, b = math.log(left), math.log(right)  # thirds of the bracket in log τn
            inner.append((math.exp(a + (b - a) / 3.0), math.exp(a + 2.0 * (b - a) / 3.0)))
        found = evaluate([z for pair in inner for z in pair])
        for k, bracket in enumerate(live):
            one, two = found[2 * k], found[2 * k + 1]
            for c in (one, two):
                if value(c) > value(bracket[2]):
                    bracket[2] = c
            # Keep the two thirds around the better inner point (ties: the left one).
            if value(two) > value(one):
                bracket[0] = one.zero
            else:
                bracket[1] = two.zero
            if not (bracket[0] <= bracket[2].zero <= bracket[1]):
                # The bracket's best stays inside it: an end may beat both inner points.
                bracket[0], bracket[1] = min(bracket[0], bracket[2].zero), max(bracket[1], bracket[2].zero)
    # The first tried of the largest.
    best = max((c for c in tried if not c.bound), key=lambda c: c.capacity, default=best)
    return Search(best, tried, resolution)


__all__ = ["Candidate", "Search", "grid", "peaks", "search", "RESOLUTION", "PEAKS", "ROUNDS"]
