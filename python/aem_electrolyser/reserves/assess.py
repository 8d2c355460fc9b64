"""One product's assessment on the packaged FMU: its tests run at a capacity C [W], evaluated;
the largest C that passes, by bisection up to what the operating window allows.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from . import evaluate, frequency_domain, report, signals
from .bisection import CapacityResult, failing, largest_capacity, most_steps
from aem_electrolyser.hub.runner import HubRunner
from .products import Product, window_bound
from .requirement import Trace


#: Tests whose requirement is full activation by a time (a tolerance applies).
FULL_ACTIVATION = ("ce_fcr_steps", "ffr_step", "frr_step")


@dataclass
class Run:
    """The tests of one product at capacity C: (signal, trace) per test, the sine points, and
    every requirement."""

    capacity: float
    tests: list = field(default_factory=list)
    points: list = field(default_factory=list)
    results: list = field(default_factory=list)


#: Steps per period of the sine tests: the FMU holds the frequency over a step, which delays it
#: by half a step, 360°/(2·500) = 0.36° at every period (next to nothing against the 1 s
#: measurement filter); never coarser than the other tests' step.
SINE_STEPS_PER_PERIOD = 500


def sine_step(period: float, dt: float) -> float:
    """The sine test's step [s]: at most `dt` and period/SINE_STEPS_PER_PERIOD, and a whole
    fraction of the period (so that the test ends on its grid)."""
    step = min(dt, period / SINE_STEPS_PER_PERIOD)
    steps = period / step
    if abs(steps - round(steps)) <= 1e-9 * steps:
        return step
    return period / math.ceil(steps)


def full_activation_tolerance(capacity: float) -> float:
    """What "full activation" may lack, as a fraction of C: the power-measurement accuracy of
    the Nordic test programme (NTP Table 1): 5 % below 1.5 MW, 1 % up to 10 MW, 0.5 % above.
    No source states a tolerance for full activation; this is our assumption."""
    return 0.05 if capacity < 1.5e6 else 0.01 if capacity < 10e6 else 0.005


def run_product(runner: HubRunner, product: Product, capacity: float, dt: float = 0.1) -> Run:
    """Every test of `product` at `capacity` [W] on a fresh FMU instance each. The sine tests
    (the longest) run only if the time-domain tests leave the capacity possible."""
    out = Run(capacity)
    parameters = dict(product.parameters)
    if product.capacity_parameter is not None:
        parameters[product.capacity_parameter] = capacity
    for signal in product.tests(dt):
        t = trace(runner, signal, capacity, parameters)
        out.tests.append((signal, t))
        options = {"tolerance": full_activation_tolerance(capacity)} if signal.kind in FULL_ACTIVATION else {}
        out.results += evaluate.evaluate(t, capacity, signal, **options)
    if product.sine is None or failing(out.results, product.use_reduction):
        return out
    for period in signals.sine_periods(product.sine):
        signal = signals.sine_test(product.sine, period, sine_step(period, dt))
        t = trace(runner, signal, capacity, parameters)
        out.points.append(frequency_domain.sine_point(t, capacity, signal))
    if out.points:
        out.results += frequency_domain.evaluate_sine_set(out.points, product.sine)
    return out


def trace(runner: HubRunner, signal, capacity: float, parameters: dict) -> Trace:
    """The hub's consumption through `signal`: driven by its frequency, or (aFRR, mFRR) by the
    power reference baseline − request·C."""
    if signal.f is not None:
        power, request = runner.run(signal.t, frequency=signal.f, parameters=parameters)
    else:
        reference = runner.baseline - np.asarray(signal.request) * capacity
        power, request = runner.run(signal.t, power_reference=reference, parameters=parameters)
        request = reference - runner.baseline
    return Trace(signal.t, power, runner.resting_power, f=signal.f, reserve_request=request)


def largest(runner: HubRunner, product: Product, dt: float = 0.1, tolerance: float = None, on_step=None):
    """(CapacityResult, Run at the result, Run just above it): bisection on (0, window bound]
    [W]. The Run at the result is None if no capacity passes, the Run above is None if the upper
    bound passes; both are None if the window allows nothing (then nothing runs).
    on_step(n, most, C, passed) is called after each capacity tried (n = 1, 2, … of at most
    `most`)."""
    upper = window_bound(product, runner.baseline, runner.least_power, runner.rated_power)
    most = most_steps(upper, runner.rated_power, tolerance)
    runs = {}

    def attempt(c):
        runs[c] = run_product(runner, product, c, dt)
        if on_step is not None:
            on_step(len(runs), most, c, not failing(runs[c].results, product.use_reduction))
        return runs[c]

    result: CapacityResult = largest_capacity(
        attempt,
        lambda r, c: r.results,
        upper,
        runner.rated_power,
        tolerance=tolerance,
        use_reduction=product.use_reduction,
    )
    at = runs.get(result.capacity) if result.capacity > 0 else None
    if at is None and result.capacity > 0:
        at = run_product(runner, product, result.capacity, dt)
    above = runs.get(result.above_capacity) if result.above_capacity is not None else None
    return result, at, above


def shown(result: CapacityResult, at: Run, above: Run) -> Run:
    """The run a report and its plots show: at the passing capacity, or, if none passes, at the
    bisection's last failing point (the smallest capacity tried); None if nothing ran."""
    return at if result.capacity > 0 else above


def section(product: Product, result: CapacityResult, at: Run, above: Run = None) -> report.Section:
    """The report's section: the requirements at the largest passing capacity (or, if none
    passes, at the smallest capacity tried, where the failure shows)."""
    run = shown(result, at, above)
    if result.window_empty:
        notes = [
            f"not tested: the operating window allows no {product.name} at this baseline (bound {result.upper:.0f} W)"
        ]
    else:
        n = len(result.history)
        notes = [
            f"searched up to the operating window's bound, {result.upper:.0f} W; bisection tried "
            f"{n} capacit{'y' if n == 1 else 'ies'}"
        ]
    results = run.results if run is not None else result.above
    return report.Section(
        product.name,
        results,
        run.capacity if run is not None else None,
        result,
        notes,
        use_reduction=product.use_reduction,
    )
