"""The reserve control's search (aem_electrolyser.reserves.optimise) on a synthetic unit whose
best control is known in closed form: the capacity the ramp test allows rises with the zero's
logarithm, the one the stability margin allows falls with it, both quantised to the bisection's
resolution (0.5 % of rated power); the best zero is where they cross."""

import math

import pytest

from aem_electrolyser.reserves import optimise

LO, HI, RATED = 1.995, 113.568, 1e6
TZ = 95.371
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


def test_the_grid_is_logarithmic_within_its_resolution_and_holds_the_known_controls():
    points = optimise.grid(LO, HI, known=(95.371, HI, 500.0))
    assert points[0] == LO and points[-1] == HI
    assert 95.371 in points and 500.0 not in points
    ratios = [b / a for a, b in zip(points, points[1:]) if 95.371 not in (a, b)]
    assert max(ratios) == pytest.approx(min(ratios), rel=1e-12)
    assert max(b / a for a, b in zip(points, points[1:])) <= optimise.RESOLUTION
    # The fewest points that keep neighbours within the resolution.
    assert len(points) - 2 == math.ceil(math.log(HI / LO) / math.log(optimise.RESOLUTION))  # 95.371 too
    with pytest.raises(ValueError):
        optimise.grid(0.0, 10.0)
    with pytest.raises(ValueError):
        optimise.grid(LO, HI, resolution=1.0)


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
    # The search's resolution in x = ln(z/τp1)/ln(τp2/τp1): two scan intervals shrunk by
    # thirds each round; within it the capacity can miss the best by its slope times that.
    scan = len(optimise.grid(LO, HI))
    width = 2.0 / (scan - 1) * (2.0 / 3.0) ** optimise.ROUNDS
    slope = RATED * max(shape[0], shape[1])
    assert found.best.capacity >= math.floor(best / STEP) * STEP - slope * width - STEP
    assert found.best.capacity == synthetic(found.best.zero, *shape)
    # ... and the zero within the plateau the bisection's steps make around the crossing.
    plateau = STEP / (RATED * min(shape[0], shape[1]))
    assert abs(position(found.best.zero) - position(zero)) < width + plateau
    # Bounded effort: the scan (with the known zero inside it) and at most two a round for each
    # refined peak, each zero asked for once.
    asked = [z for call in calls for z in call]
    assert len(asked) == len(set(asked)) <= scan + 1 + 2 * optimise.PEAKS * optimise.ROUNDS
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


def test_margins_are_distances_inside_the_limits_relative_to_their_scale():
    from aem_electrolyser.reserves.margins import of_requirement
    from aem_electrolyser.reserves.requirement import Requirement

    def req(name, measured, low=None, high=None, status="pass", k_red=None, k_range=None):
        return Requirement(name, measured, "", low, high, "s", status, k_red, k_range)

    assert of_requirement(req("Req. 3", 0.5, low=0.4)).relative == pytest.approx(0.25)
    assert of_requirement(req("Req. 4", 7.0, high=10.0)).distance == pytest.approx(3.0)
    assert of_requirement(req("Req. 1", 12.0, low=0.0, high=10.0, status="fail")).relative == pytest.approx(-0.2)
    # The Nyquist distance against the radius 0.43: 0.43·0.95 + 0.0215 is 5 % of it inside.
    assert of_requirement(req("Req. 8", 0.43 * 0.95 + 0.0215, low=0.43 * 0.95)).relative == pytest.approx(0.05)
    # A failing requirement that a reduction factor covers: K_red above its floor.
    covered = of_requirement(req("Req. 2", 0.7, low=0.86, status="fail", k_red=0.81, k_range=(0.75, 1.0)))
    assert covered.distance == pytest.approx(0.06) and "K_red" in covered.name
    assert of_requirement(req("Req. 9", 1.0)) is None


def banded(z, bands):
    """A capacity that passes only inside bands [(lo [s], hi [s], top [W])], a tent in ln z
    inside each (0 at its ends), on the bisection's grid: what FCR-N's capacity over the zero
    looks like (the steady state fails on one side of a band, the stability margin on the
    other)."""
    best = 0.0
    for lo, hi, top in bands:
        if lo < z < hi:
            x = math.log(z / lo) / math.log(hi / lo)
            best = max(best, top * (1.0 - abs(2.0 * x - 1.0)))
    return math.floor(best / STEP) * STEP


#: A band of 20 % in the zero (the width FCR-N's band had at 80 % on a 100-module hub), a wider
#: but lower one, and a narrow one barely above the resolution.
BANDS = [(40.0, 48.0, 0.05 * RATED), (4.0, 9.0, 0.02 * RATED), (70.0, 70.0 * 1.06, 0.04 * RATED)]


def test_the_scan_finds_a_band_the_old_seven_point_grid_stepped_over():
    """The capacity is 0 outside the bands: the best is the tallest band's top, which the scan
    must find (as much as a brute force on a fine grid finds); seven log-spaced zeros with one
    bracket, as the search was, step over it and find only the lower, wider band."""
    found = optimise.search(lambda zs: [banded(z, BANDS) for z in zs], LO, HI, known=(95.371, HI))
    brute = max(banded(z, BANDS) for z in optimise.grid(LO, HI, resolution=1.0005))
    assert brute > 0 and found.best.capacity == brute
    assert BANDS[0][0] < found.best.zero < BANDS[0][1]
    old = optimise.search(
        lambda zs: [banded(z, BANDS) for z in zs],
        LO,
        HI,
        known=(95.371, HI),
        resolution=(HI / LO) ** (1 / 6),
        count=1,
    )
    assert old.best.capacity < 0.5 * brute  # the lower, wider band only


@pytest.mark.parametrize("start", [1.0, 1.011, 1.024, 1.037, 1.049])
def test_every_band_wider_than_the_resolution_holds_a_scan_point(start):
    """A band of zeros [a, a·RESOLUTION] anywhere in the range holds a scan point, so the search
    sells something; a band narrower than the resolution may fall between two."""
    a = LO * (HI / LO) ** 0.37 * start
    band = [(a, a * optimise.RESOLUTION * (1 + 1e-9), 0.05 * RATED)]
    found = optimise.search(lambda zs: [banded(z, band) for z in zs], LO, HI)
    assert found.best.capacity > 0


def test_peaks_are_the_best_local_maxima_first_plateaus_once():
    caps = [0, 5, 5, 0, 3, 0, 7, 7, 7, 2, 9]
    points = [optimise.Candidate(float(k + 1), float(c)) for k, c in enumerate(caps)]
    assert optimise.peaks(points, 3) == [10, 6, 1]
    assert optimise.peaks([optimise.Candidate(1.0, 0.0), optimise.Candidate(2.0, 0.0)]) == [0]


@pytest.mark.parametrize("shape", [(0.3, 0.25, 0.05), (0.1, 0.5, 0.02)], ids=["middle", "near compensation"])
def test_the_branch_and_bound_finds_what_the_full_scan_finds_with_fewer_full_searches(shape):
    """With `beats` (does a zero pass just above a capacity?) the scan searches in full only the
    zeros that can beat the best so far: the same best (the capacity is monotone in the offer,
    as the bisection assumes), fewer bisections."""
    full_calls, beats_calls = [], []

    def capacities(zeros):
        full_calls.extend(zeros)
        return [synthetic(z, *shape) for z in zeros]

    def beats(zeros, floor):
        beats_calls.extend(zeros)
        return [synthetic(z, *shape) >= floor + STEP for z in zeros]

    plain = optimise.search(lambda zs: [synthetic(z, *shape) for z in zs], LO, HI, known=(95.371, HI))
    pruned = optimise.search(capacities, LO, HI, known=(95.371, HI), beats=beats)
    assert pruned.best.capacity == plain.best.capacity
    assert len(full_calls) < len(plain.tried) / 3
    assert len(full_calls) + len(beats_calls) <= len(plain.tried) + len(optimise.grid(LO, HI))
    # Every zero not searched in full is bounded by the best at the time, which it did not beat.
    for c in pruned.tried:
        if c.bound:
            assert synthetic(c.zero, *shape) < c.capacity + STEP


def test_the_branch_and_bound_finds_the_band():
    def beats(zeros, floor):
        return [banded(z, BANDS) >= floor + STEP for z in zeros]

    found = optimise.search(lambda zs: [banded(z, BANDS) for z in zs], LO, HI, known=(95.371, HI), beats=beats)
    assert found.best.capacity == max(banded(z, BANDS) for z in optimise.grid(LO, HI, resolution=1.0005))


@pytest.mark.slow
def test_on_the_fmu_the_scan_sells_fcr_n_where_the_seven_point_grid_sold_nothing(fmu_path):
    """FCR-N on an equal hub at 80 % (4 modules; an equal hub's percentages do not depend on its
    size) passes only for zeros in a band around 40–50 s (the steady state fails below it,
    stability above). The seven-point grid with one bracket, as the search was, sells nothing;
    the scan finds the band, and what it reports is what a bisection at its zero sells."""
    from aem_electrolyser.hub.runner import Hub, HubRunner
    from aem_electrolyser.reserves import assess
    from aem_electrolyser.reserves.bisection import failing
    from aem_electrolyser.reserves.products import BY_NAME, window_bound

    spec, runners = BY_NAME["FCR-N"], {}

    def runner(z):
        if z not in runners:
            runners[z] = HubRunner(fmu_path, Hub(4, 1, 0, 0.8, False, (), 0.0 if z == TZ else z))
        return runners[z]

    def capacities(zs):
        return [assess.largest(runner(z), spec, 0.1)[0].sellable for z in zs]

    def beats(zs, floor):
        out = []
        for z in zs:
            r = runner(z)
            c = floor + 0.005 * r.rated_power
            fits = c <= window_bound(spec, r.baseline, r.least_power, r.rated_power)
            out.append(fits and not failing(assess.run_product(r, spec, c, 0.1).results, spec.use_reduction))
        return out

    try:
        old = optimise.search(capacities, LO, HI, known=(TZ, HI), resolution=(HI / LO) ** (1 / 6), count=1)
        new = optimise.search(capacities, LO, HI, known=(TZ, HI), beats=beats)
        rated = runner(TZ).rated_power
        assert old.best.capacity == 0.0
        assert 40.0 < new.best.zero < 55.0
        assert new.best.capacity > 0.15 * rated
        assert capacities([new.best.zero]) == [new.best.capacity]
    finally:
        for r in runners.values():
            r.close()
