"""The reserve control's search (aem_electrolyser.reserves.optimise) on a synthetic unit whose
best control is known in closed form: the capacity the ramp test allows rises with the zero's
logarithm, the one the stability margin allows falls with it, both quantised to the bisection's
resolution (0.5 % of rated power); the best zero is where they cross."""

import math

import pytest

from aem_electrolyser.reserves import optimise

LO, HI, RATED = 1.995, 113.568, 1e6
STEP = 0.005 * RATED  # the bisection's resolution


def position(z):
    return math.log(z / LO) / math.log(HI / LO)


def synthetic(z, rise=0.3, fall=0.25, floor=0.05):
    """min(ramp-limited, stability-limited) capacity [W], on the bisection's grid."""
    x = position(z)
    exact = RATED * min(rise * x, floor + fall * (1.0 - x))
    return math.floor(exact / STEP) * STEP


def crossing(rise=0.3, fall=0.25, floor=0.05):
    """(zero [s], capacity [W]) where rise·x = floor + fall·(1 − x), or at τp2 (x = 1) if the
    ramp limit binds throughout."""
    x = min((floor + fall) / (rise + fall), 1.0)
    return LO * (HI / LO) ** x, RATED * rise * x


def test_the_grid_is_logarithmic_and_holds_the_known_controls():
    points = optimise.grid(LO, HI, 7, known=(95.371, HI, 500.0))
    assert points[0] == LO and points[-1] == HI
    assert 95.371 in points and 500.0 not in points
    ratios = [b / a for a, b in zip(points, points[1:]) if 95.371 not in (a, b)]
    assert max(ratios) == pytest.approx(min(ratios), rel=1e-12)
    with pytest.raises(ValueError):
        optimise.grid(0.0, 10.0)


@pytest.mark.parametrize(
    "shape",
    [(0.3, 0.25, 0.05), (0.6, 0.1, 0.02), (0.1, 0.5, 0.02), (0.1, 0.5, 0.3)],
    ids=["middle", "near plain", "near compensation", "compensation itself"],
)
def test_the_search_finds_the_crossing_of_the_two_limits(shape):
    calls = []

    def capacities(zeros):
        calls.append(list(zeros))
        return [synthetic(z, *shape) for z in zeros]

    found = optimise.search(capacities, LO, HI, known=(95.371, HI))
    zero, best = crossing(*shape)
    # The search's resolution in x = ln(z/τp1)/ln(τp2/τp1): two grid intervals shrunk by
    # thirds each round; within it the capacity can miss the best by its slope times that.
    width = 2.0 / (optimise.GRID - 1) * (2.0 / 3.0) ** optimise.ROUNDS
    slope = RATED * max(shape[0], shape[1])
    assert found.best.capacity >= math.floor(best / STEP) * STEP - slope * width - STEP
    assert found.best.capacity == synthetic(found.best.zero, *shape)
    assert abs(position(found.best.zero) - position(zero)) < width
    # Bounded effort: the grid (7 + the known zero inside it) and at most two a round, each
    # zero asked for once.
    asked = [z for call in calls for z in call]
    assert len(asked) == len(set(asked)) <= 8 + 2 * optimise.ROUNDS
    assert len(found.tried) == len(asked)
    # Reproducible: the same answer from the same inputs.
    again = optimise.search(lambda zs: [synthetic(z, *shape) for z in zs], LO, HI, known=(95.371, HI))
    assert again.best == found.best and again.tried == found.tried


def test_a_flat_capacity_keeps_the_first_grid_point_and_asks_nothing_twice():
    calls = []

    def flat(zeros):
        calls.extend(zeros)
        return [STEP] * len(zeros)

    found = optimise.search(flat, LO, HI)
    assert found.best.zero == LO
    assert len(calls) == len(set(calls))


def test_margins_are_relative_distances_inside_the_limits():
    class R:
        def __init__(self, measured, low=None, high=None):
            self.measured, self.low, self.high = measured, low, high

    assert optimise.margin(R(0.5, low=0.4)) == pytest.approx(0.25)
    assert optimise.margin(R(7.0, high=10.0)) == pytest.approx(0.3)
    assert optimise.margin(R(12.0, low=0.0, high=10.0)) == pytest.approx(-0.2)
    assert optimise.margin(R(1.0)) == math.inf
