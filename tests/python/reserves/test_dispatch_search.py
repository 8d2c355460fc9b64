"""The dispatch that sells the most (aem_electrolyser.reserves.dispatch_search, aem-prequalify
--optimise-dispatch): the feasible running counts and their target setpoints in closed form, the
packaged FMU running exactly the count a target setpoint stands for, and the search against a
brute-force assessment of every count of a small hub."""

import math

import pytest
from fmpy import read_model_description

from aem_electrolyser.hub.driver import HubFMU
from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, dispatch_search
from aem_electrolyser.reserves.products import BY_NAME
from conftest import PAPER

CURVE = dispatch_search.ModuleCurve(
    PAPER["gain"], PAPER["voltageIntercept"], PAPER["ohmicResistance"], PAPER["minSetpoint"], PAPER["maxSetpoint"]
)


def test_the_curve_and_its_inverse_are_the_polarisation_curve():
    for u in (60.0, 72.5, 100.0):
        i = PAPER["gain"] * u
        assert CURVE.power(u) == pytest.approx(
            (PAPER["voltageIntercept"] + PAPER["ohmicResistance"] * i) * i, rel=1e-15
        )
        assert CURVE.setpoint(CURVE.power(u)) == pytest.approx(u, rel=1e-13)


def test_the_feasible_counts_keep_every_running_module_inside_its_window():
    p_min, p_max = CURVE.power(60.0), CURVE.power(100.0)
    for n_modules, base in ((10, 5 * p_max), (40, 13.3 * p_max), (7, 6.9 * p_max), (25_000, 0.35 * 25_000 * p_max)):
        counts = dispatch_search.feasible_counts(n_modules, base, CURVE)
        assert counts[0] == math.ceil(base / p_max) and counts[-1] == min(n_modules, math.floor(base / p_min))
        for n in counts:
            assert p_min * n <= base * (1 + 1e-12) and base <= p_max * n * (1 + 1e-12)
            assert 60.0 <= dispatch_search.target_setpoint(n, base, CURVE) <= 100.0
    # Between one module's maximum and two modules' minimum no count fits.
    assert len(dispatch_search.feasible_counts(10, 1.1 * p_max, CURVE)) == 0


@pytest.mark.parametrize("count", [5, 7, 9])
def test_the_fmu_runs_the_count_its_target_setpoint_stands_for(fmu_path, count):
    """Target dispatch at dispatchTargetSetpoint = u(B/n) runs n modules, each drawing B/n."""
    n_modules, base = 10, 5 * CURVE.power(100.0)
    target = dispatch_search.target_setpoint(count, base, CURVE)
    with HubFMU(
        fmu_path, nModules=n_modules, dispatch=4, belowMinimum=1, powerInput=True, dispatchTargetSetpoint=target
    ) as hub:
        hub.initialize(powerReference=base)
        hub.step(60.0, powerReference=base)
        assert hub.get("modulesRunning") == count
        assert hub.get("hubPower") == pytest.approx(base, rel=1e-9)


def test_the_search_finds_the_brute_force_optimum_of_a_small_hub(fmu_path):
    """Downward aFRR of a 24-module hub at half its rated power: every feasible count assessed
    on the FMU (brute force) against the search (forced, not exhaustive: its scan, which at 5 %
    holds nearly every count of so small a hub, and its refinement), which asks each count once
    and finds the same best capacity. (Downward FCR-D with plain droop sells at no count: its
    curve comes too close to −1 between the prescribed periods.)"""
    n_modules, baseline, product = 24, 0.5, BY_NAME["aFRR down"]
    rated = n_modules * CURVE.power(100.0)
    counts = dispatch_search.feasible_counts(n_modules, baseline * rated, CURVE)
    assert (counts[0], counts[-1]) == (12, 21)  # all at 100 % … near 60 %
    assert read_model_description(str(fmu_path))  # the packaged FMU
    cache = {}

    def capacity(n):
        if n not in cache:
            hub = Hub(
                n_modules,
                4,
                1,
                baseline,
                dispatch_target=dispatch_search.target_setpoint(n, baseline * rated, CURVE),
            )
            runner = HubRunner(fmu_path, hub)
            try:
                cache[n] = assess.largest(runner, product, 0.1)[0].sellable
            finally:
                runner.close()
        return cache[n]

    brute = {n: capacity(n) for n in counts}
    asked = []

    def capacities(ns):
        asked.extend(ns)
        return [capacity(n) for n in ns]

    found = dispatch_search.search(capacities, counts, exhaustive=0)
    best = max(brute.values())
    assert found.capacity == best and brute[found.count] == best
    assert found.count == min(n for n, c in brute.items() if c == best)  # ties: the fewest modules
    assert len(set(asked)) == len(asked) <= len(counts)
    # Downward aFRR needs headroom above the running modules: none at 100 %, some with more.
    assert brute[counts[0]] == 0.0 and best > 0.0
