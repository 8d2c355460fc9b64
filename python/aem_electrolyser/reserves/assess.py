"""One product's assessment on the packaged FMU: its tests run at a capacity C [W], evaluated;
the largest C that passes, by bisection up to what the operating window allows.
"""

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import evaluate, frequency_domain, margins, report, signals
from .bisection import CapacityResult, failing, largest_capacity, most_steps
from aem_electrolyser.hub.runner import HubRunner
from .products import Product, window_bound
from .requirement import Trace


#: Tests whose requirement is full activation by a time (a tolerance applies).
FULL_ACTIVATION = ("ce_fcr_steps", "ffr_step", "frr_step")


@dataclass
class Run:
    """The tests of one product at capacity C: (signal, trace) per test, the sine points at
    the prescribed periods, the dense curve (every sine test, prescribed and between), and every
    requirement."""

    capacity: float
    tests: list = field(default_factory=list)
    points: list = field(default_factory=list)
    results: list = field(default_factory=list)
    dense: Optional[frequency_domain.DenseCurve] = None
    readings: list = field(default_factory=list)
    margin: float = 0.0


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


def run_product(runner: HubRunner, product: Product, capacity: float, dt: float = 0.1, margin: float = 0.0) -> Run:
    """Every test of `product` at `capacity` [W] on a fresh FMU instance each. The sine tests
    (the longest) run only if the time-domain tests leave the capacity possible, the dense
    curve's only if the prescribed periods pass. Every result is read again under the choices
    the rules leave open (margins.readings). With a `margin` > 0 Req. 8 asks for 0.43·(0.95 +
    margin) and every reading must pass too (they join the results)."""
    out = _run_product(Run(capacity, margin=margin), runner, product, capacity, dt, margin)
    out.readings = margins.readings(out, product, capacity, frequency_domain.required_distance(margin))
    if margin > 0:
        out.results += [reading_requirement(i) for i in out.readings if not i.ours]
    return out


def reading_requirement(reading: "margins.Interpretation"):
    """A reading of the rules as a requirement of its own (named with its choice)."""
    r = reading.requirement
    return dataclasses.replace(r, name=f"{r.name} [{reading.choice}]")


def _run_product(out: Run, runner: HubRunner, product: Product, capacity: float, dt: float, margin: float) -> Run:
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
    prescribed = signals.sine_periods(product.sine)
    for period in prescribed:
        out.points.append(sine(runner, product.sine, period, capacity, parameters, dt))
    if not out.points:
        return out
    at_prescribed = frequency_domain.evaluate_sine_set(out.points, product.sine, margin=margin)
    if failing(out.results + at_prescribed, product.use_reduction):
        # Failing already: the dense curve cannot save it (it only adds a requirement).
        out.results += at_prescribed
        return out
    required = frequency_domain.required_distance(margin)
    out.dense = dense_curve(runner, product, capacity, parameters, dt, out.points, required=required)
    out.results += frequency_domain.evaluate_sine_set(out.points, product.sine, out.dense, margin)
    return out


#: The sine tests' lead-in (the periods before the fitted ones) lasts at least this many of the
#: unit's slowest time constant: the sine's start excites the slow pole, whose transient a fit
#: with an offset does not absorb; after three of them e^−3 = 5 % of it is left (with the NTR's
#: recommended totals alone, 80 s at T = 40 s, half of it: F off by 0.5 %).
LEAD_IN_TIME_CONSTANTS = 3.0


def slowest_time_constant(runner: HubRunner) -> float:
    """The unit's slowest pole [s]: tauPole1 or tauPole2 as the hub sets them."""
    value = dict(runner.hub.settings)
    return max(float(value.get(n, runner.vars[n].start)) for n in ("tauPole1", "tauPole2"))


def sine(
    runner: HubRunner,
    name: str,
    period: float,
    capacity: float,
    parameters: dict,
    dt: float,
    settle: Optional[float] = None,
    amplitude: Optional[float] = None,
    lead: Optional[float] = None,
):
    """One sine test at `period` [s]: its SinePoint. The fitted periods are the NTR's (Table 6)
    for a prescribed period and those of the prescribed period just below for one between; the
    lead-in before them lasts as long as the NTR's recommended total makes it (between
    prescribed periods: the longer of its neighbours') and at least `lead` [s] (default
    LEAD_IN_TIME_CONSTANTS times the unit's slowest time constant). `settle` [s] lengthens the
    time at the centre frequency before the sine, `amplitude` [Hz] replaces the test's 0.1 Hz."""
    kwargs = {k: v for k, v in (("settle", settle), ("amplitude", amplitude)) if v is not None}
    if lead is None:
        lead = LEAD_IN_TIME_CONSTANTS * slowest_time_constant(runner)
    kwargs.update(zip(("n_stationary", "n_total"), periods(period, lead)))
    signal = signals.sine_test(name, period, sine_step(period, dt), **kwargs)
    return frequency_domain.sine_point(trace(runner, signal, capacity, parameters), capacity, signal)


def periods(period: float, lead: float = 0.0) -> tuple:
    """(fitted periods, total periods) of a sine test at `period` [s] whose lead-in lasts at
    least `lead` [s]."""
    table = sorted(signals.SINE_PERIODS.items())
    below = [(T, v) for T, v in table if T <= period] or table[:1]
    above = [(T, v) for T, v in table if T >= period] or table[-1:]
    ntr = max((nt - ns) * T for T, (ns, nt) in (below[-1], above[0]))
    stationary = below[-1][1][0]
    return stationary, stationary + math.ceil(max(ntr, lead) / period - 1e-9)


def dense_curve(
    runner,
    product: Product,
    capacity: float,
    parameters: dict,
    dt: float,
    points: list,
    amplitude: Optional[float] = None,
    required: Optional[float] = None,
):
    """Sine tests between the prescribed periods until the dense curve's bound holds and its
    verdict against `required` is certain (frequency_domain.refine_periods), at most
    frequency_domain.DENSE_MOST of them."""
    tested = list(points)
    asked = frequency_domain.start_periods([p.period for p in points])
    while asked and len(tested) - len(points) < frequency_domain.DENSE_MOST:
        asked = asked[: frequency_domain.DENSE_MOST - (len(tested) - len(points))]
        tested += [sine(runner, product.sine, T, capacity, parameters, dt, amplitude=amplitude) for T in asked]
        asked = frequency_domain.refine_periods(tested, product.sine, required=required)
    return frequency_domain.dense_curve(tested, product.sine, required=required)


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


def largest(
    runner: HubRunner, product: Product, dt: float = 0.1, tolerance: float = None, on_step=None, margin: float = 0.0
):
    """(CapacityResult, Run at the result, Run just above it): bisection on (0, window bound]
    [W]. The Run at the result is None if no capacity passes, the Run above is None if the upper
    bound passes; both are None if the window allows nothing (then nothing runs).
    on_step(n, most, C, passed) is called after each capacity tried (n = 1, 2, … of at most
    `most`)."""
    upper = window_bound(product, runner.baseline, runner.least_power, runner.rated_power)
    most = most_steps(upper, runner.rated_power, tolerance)
    runs = {}

    def attempt(c):
        runs[c] = run_product(runner, product, c, dt, margin)
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
        at = run_product(runner, product, result.capacity, dt, margin)
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
    if run is not None and run.margin > 0:
        notes.append(
            f"sold with a stated margin of {run.margin:g}: Req. 8 asks for 0.43·(0.95 + {run.margin:g}) and every "
            "reading of the rules below must pass"
        )
    elif run is not None:
        notes.append("judged at the rules' own limits (no stated margin)")
    if run is not None and run.dense is not None:
        notes.append(
            f"dense Nyquist curve: {len(run.dense.points)} sine tests ({len(run.points)} prescribed), smallest distance "
            f"{run.dense.minimum:.4f} at T = {run.dense.at_period:.4g} s, certified ≥ {run.dense.bound:.4f} between them"
        )
    return report.Section(
        product.name,
        results,
        run.capacity if run is not None else None,
        result,
        notes,
        use_reduction=product.use_reduction,
        margins=margins.of_run(results, run.capacity, result.upper, result.rated_power) if run is not None else [],
        readings=list(run.readings) if run is not None else [],
    )
