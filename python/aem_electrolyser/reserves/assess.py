"""One product's assessment on the packaged FMU: its tests run at a capacity C [W], evaluated;
the largest C that passes, by bisection up to what the operating window allows.
"""
from dataclasses import dataclass, field

import numpy as np

from . import evaluate, frequency_domain, report, signals
from .bisection import CapacityResult, failing, largest_capacity
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
        signal = signals.sine_test(product.sine, period, min(dt, period / SINE_STEPS_PER_PERIOD))
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
    return Trace(signal.t, power, runner.baseline, f=signal.f, reserve_request=request)


def largest(runner: HubRunner, product: Product, dt: float = 0.1, tolerance: float = None):
    """(CapacityResult, Run at the result): bisection on (0, window bound] [W]."""
    upper = window_bound(product, runner.baseline, runner.least_power, runner.rated_power)
    runs = {}

    def attempt(c):
        runs[c] = run_product(runner, product, c, dt)
        return runs[c]

    result: CapacityResult = largest_capacity(attempt, lambda r, c: r.results, upper, runner.rated_power,
                                              tolerance=tolerance, use_reduction=product.use_reduction)
    at = runs.get(result.capacity) if result.capacity > 0 else None
    if at is None and result.capacity > 0:
        at = run_product(runner, product, result.capacity, dt)
    return result, at


def section(product: Product, result: CapacityResult, at: Run) -> report.Section:
    """The report's section: the requirements at the largest passing capacity (or, if none
    passes, just above 0, where the failure shows)."""
    results = at.results if at is not None else result.above
    notes = [f"searched up to the operating window's bound; bisection tried {len(result.history)} capacities"]
    if result.reduced_capacity is not None and result.reduced_capacity < result.capacity:
        notes.append(f"with the reduction factors the capacity is {result.reduced_capacity:.6g} W")
    return report.Section(product.name, results, at.capacity if at is not None else None, result, notes)
