"""Frequency reserves in the packaged FMU, through fmpy, against closed forms.

The request of each product at its band edges and beyond (reserveRequest); a constant
frequency below 49.5 Hz takes exactly fcrDUpCapacity off the hub's draw at steady state; the
FCR-D ramp of the test programme (a staircase of held frequencies) gives the current of the
superposed closed-form step responses of G(s); compensation keeps the current inside the
window's currents and under the ramp limit; FFR holds for its support duration; bad values
are refused with the instance intact; an FMU state taken while FFR is active replays bit for bit.
"""

import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from conftest import PAPER, modal_weights, module_power, setpoint_for

K, RAMP = PAPER["gain"], PAPER["rampUpLimit"]
TAU1, TAU2 = PAPER["tauPole1"], PAPER["tauPole2"]


def hub(driver, n=4, power=None, setpoint=100.0, reals=None, compensation=False):
    """An initialised hub of n modules (equal dispatch, staying at the minimum), driven by a
    power reference [W] if one is given, else by the setpoint."""
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setInteger([d.vr["nModules"]], [n])
    d.fmu.setBoolean([d.vr["powerInput"], d.vr["reserveCompensation"]], [power is not None, compensation])
    d.set(setpoint=setpoint, powerReference=power or 0.0, **(reals or {}))
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    return d


def closed_form_request(f, c_n=0.0, c_up=0.0, c_down=0.0, c_ce=0.0):
    clamp = lambda x, lo, hi: min(max(x, lo), hi)  # noqa: E731
    return (
        -c_n * clamp((50 - f) / 0.1, -1, 1)
        - c_up * clamp((49.9 - f) / 0.4, 0, 1)
        + c_down * clamp((f - 50.1) / 0.4, 0, 1)
        - c_ce * clamp((50 - f) / 0.2, -1, 1)
    )


@pytest.mark.parametrize(
    "product, capacities, frequencies",
    [
        ("fcrNCapacity", dict(c_n=1000.0), [50.0, 49.95, 49.9, 49.8, 50.05, 50.1, 50.4]),
        ("fcrDUpCapacity", dict(c_up=1000.0), [50.0, 49.9, 49.8, 49.5, 49.2, 50.3]),
        ("fcrDDownCapacity", dict(c_down=1000.0), [50.0, 50.1, 50.3, 50.5, 50.9, 49.0]),
        ("fcrCapacity", dict(c_ce=1000.0), [50.0, 49.99, 49.9, 49.8, 49.5, 50.2, 50.6]),
    ],
)
def test_each_product_asks_its_activation_at_the_band_edges_and_beyond(driver, product, capacities, frequencies):
    d = hub(driver, power=4 * module_power(80.0), reals={product: 1000.0})
    for f in frequencies:
        d.set(frequency=f)
        assert d.get("reserveRequest") == pytest.approx(closed_form_request(f, **capacities), abs=1e-9), f


def test_below_49_5_hz_the_hub_draws_exactly_the_fcr_d_capacity_less(driver):
    baseline, capacity = 4 * module_power(85.0), 1500.0
    d = hub(driver, power=baseline, reals={"fcrDUpCapacity": capacity})
    d.set(frequency=49.3)
    for _ in range(100):
        d.fmu.doStep(currentCommunicationPoint=d.time, communicationStepSize=30.0)
        d.time += 30.0
    # 3000 s: 26 slow time constants after the step.
    assert d.get("hubPower") == pytest.approx(baseline - capacity, rel=1e-9)
    # In setpoint mode the capacity comes off the power the setpoint stands for.
    s = hub(driver, setpoint=85.0, reals={"fcrDUpCapacity": capacity, "frequency": 49.0})
    assert s.get("hubPower") == pytest.approx(baseline - capacity, rel=1e-12)


def test_the_fcr_d_ramp_gives_the_superposed_closed_form_step_responses(driver):
    """Ramp 1 of the FCR-D test (49.9 -> 49.45 Hz at 0.14 Hz/s, then held), frequency sampled
    every 0.1 s and held: a staircase of reductions. Falling current has no rate limit, so the
    current is the sum of the steps' closed-form responses K*du*(1 - a e^(-t/tp1) - b e^(-t/tp2))."""
    n, h, capacity = 4, 0.1, 2000.0
    baseline = n * module_power(90.0)
    d = hub(driver, n=n, power=baseline, reals={"fcrDUpCapacity": capacity, "frequency": 49.9})
    a, b = modal_weights()
    times = np.arange(0.0, 40.0, h)
    frequency = np.maximum(49.9 - 0.14 * times, 49.45)
    setpoints = [setpoint_for((baseline + closed_form_request(f, c_up=capacity)) / n) for f in frequency]
    expected, got = [], []
    for k, f in enumerate(frequency):
        d.set(frequency=float(f))
        d.fmu.doStep(currentCommunicationPoint=d.time, communicationStepSize=h)
        d.time += h
        t = (k + 1) * h
        steps = np.diff(np.concatenate([[90.0], setpoints[: k + 1]]))
        ages = t - times[: k + 1]
        expected.append(K * 90.0 + K * np.sum(steps * (1 - a * np.exp(-ages / TAU1) - b * np.exp(-ages / TAU2))))
        got.append(d.get("current"))
    assert np.max(np.abs(np.array(got) - expected)) < 1e-9
    # The request at 7.5 s after the ramp's start delivers about 83 % of the full reduction:
    # the fast pole's share a, less what the staircase has not yet asked.
    i75 = int(round(7.5 / h)) - 1
    delivered = (K * 90.0 - got[i75]) / (K * 90.0 - K * setpoints[-1])
    assert 0.75 < delivered < a


def test_compensation_stays_in_the_window_and_under_the_ramp_limit(driver):
    """A compensated hub under a 10 s frequency sine of +-0.3 Hz around 50 Hz with large FCR-N
    and FCR-D capacities, its power reference jumping too: the current never leaves
    [K*60, K*100] and never rises faster than rampUpLimit."""
    n, h = 3, 0.05
    capacity = n * (module_power(100.0) - module_power(60.0))
    d = hub(
        driver,
        n=n,
        power=n * module_power(80.0),
        compensation=True,
        reals={"fcrNCapacity": capacity, "fcrDUpCapacity": capacity, "fcrDDownCapacity": capacity},
    )
    rng = np.random.default_rng(5)
    previous = d.get("current")
    for k in range(int(300 / h)):
        t = k * h
        if k % 400 == 0:
            d.set(powerReference=n * module_power(rng.uniform(55.0, 105.0)))
        d.set(frequency=50.0 + 0.3 * math.sin(2 * math.pi * t / 10.0))
        d.fmu.doStep(currentCommunicationPoint=d.time, communicationStepSize=h)
        d.time += h
        current = d.get("current")
        assert K * 60.0 - 1e-9 <= current <= K * 100.0 + 1e-9, (t, current)
        assert current - previous <= RAMP * h + 1e-9, (t, current - previous)
        previous = current


def test_compensation_turns_the_fcr_d_step_into_the_fast_first_order(driver):
    n, capacity = 2, 500.0
    baseline = n * module_power(90.0)
    plain = hub(driver, n=n, power=baseline, reals={"fcrDUpCapacity": capacity})
    fast = hub(driver, n=n, power=baseline, compensation=True, reals={"fcrDUpCapacity": capacity})
    target = setpoint_for((baseline - capacity) / n)
    a, b = modal_weights()
    for d in (plain, fast):
        d.set(frequency=49.0)
        d.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=7.5)
    # At 7.5 s: compensated 1 - e^(-7.5/tp1) of the change, plain a(1 - e^(-7.5/tp1)) + b(1 - e^(-7.5/tp2)).
    share = lambda d: (K * 90.0 - d.get("current")) / (K * (90.0 - target))  # noqa: E731
    assert share(fast) == pytest.approx(1 - math.exp(-7.5 / TAU1), rel=1e-9)
    assert share(plain) == pytest.approx(a * (1 - math.exp(-7.5 / TAU1)) + b * (1 - math.exp(-7.5 / TAU2)), rel=1e-9)


def test_ffr_holds_its_capacity_for_the_support_duration(driver):
    n, capacity = 4, 800.0
    baseline = n * module_power(90.0)
    d = hub(
        driver,
        n=n,
        power=baseline,
        reals={"ffrCapacity": capacity, "ffrTriggerFrequency": 49.6, "ffrSupportDuration": 5.0},
    )
    requests = []
    for k in range(40):
        d.set(frequency=49.55 if k >= 10 else 49.8)
        requests.append(d.get("reserveRequest"))
        d.fmu.doStep(currentCommunicationPoint=d.time, communicationStepSize=0.5)
        d.time += 0.5
    # Triggered at 5.0 s, held until 10.0 s, then spent while the frequency stays low.
    assert requests[:10] == [0.0] * 10
    assert requests[10:20] == [-capacity] * 10
    assert requests[20:] == [0.0] * 20


def test_bad_reserve_values_are_refused_and_the_instance_stays_intact(driver):
    d = hub(driver, power=4 * module_power(80.0), reals={"fcrNCapacity": 100.0})
    before = d.get("hubPower", "reserveRequest")
    with pytest.raises(FMICallException):
        d.set(frequency=float("nan"))
    assert d.get("hubPower", "reserveRequest") == before
    d.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1.0)
    bad = driver(logging_on=True)
    bad.fmu.setupExperiment(startTime=0.0)
    bad.set(fcrDDownCapacity=-5.0)
    bad.fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        bad.fmu.exitInitializationMode()
    assert any("fcrDDownCapacity = -5" in m for _, _, m in bad.messages), bad.messages
    bad.set(fcrDDownCapacity=5.0)
    bad.fmu.exitInitializationMode()


def test_a_state_taken_while_ffr_is_active_replays_bit_for_bit(driver):
    n = 3
    d = hub(driver, n=n, power=n * module_power(90.0), reals={"ffrCapacity": 600.0, "fcrNCapacity": 200.0})
    d.set(frequency=49.6)
    for _ in range(5):
        d.fmu.doStep(currentCommunicationPoint=d.time, communicationStepSize=1.0)
        d.time += 1.0
    saved = d.fmu.serializeFMUstate(d.fmu.getFMUstate())
    outputs = ["hubPower", "hubEnergy", "reserveRequest", "current"]

    def run(x, t0):
        trace = []
        for k in range(60):
            x.fmu.doStep(currentCommunicationPoint=t0 + k, communicationStepSize=1.0)
            trace.append(x.get(*outputs))
        return trace

    first = run(d, d.time)
    d.fmu.setFMUstate(d.fmu.deSerializeFMUstate(saved))
    assert run(d, 5.0) == first
    assert first[40][2] == pytest.approx(-200.0 * 1.0)  # FFR's 30 s ended at 30 s; FCR-N stays
