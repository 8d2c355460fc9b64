"""The reserve control through fmpy: reserveFilterZero puts the zero of the current's transfer
function K(tn s + 1)/((tp1 s + 1)(tp2 s + 1)) at tn; its two ends are plain droop (tn = tz) and
reserveCompensation (tn = tp2), bit for bit; values outside [tp1, tp2] are refused by name.

A falling step is never rate-limited, so the current is the transfer function's step response,
written out here: I(t) = K u1 + K (u0 - u1) (a' e^(-t/tp1) + b' e^(-t/tp2)),
a' = (tn - tp1)/(tp2 - tp1), b' = 1 - a'.
"""

import math

import pytest
from fmpy.fmi1 import FMICallException

from conftest import PAPER

K, TZ, TP1, TP2 = PAPER["gain"], PAPER["tauZero"], PAPER["tauPole1"], PAPER["tauPole2"]


def hub(driver, setpoint, **reals):
    """One module as a hub (the filter needs held inputs), setpoint-driven, initialised."""
    return initialise(driver(logging_on=True), setpoint, **reals)


def initialise(d, setpoint, **reals):
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setInteger([d.vr["nModules"], d.vr["belowMinimum"]], [1, 1])
    booleans = {k: reals.pop(k) for k in list(reals) if k == "reserveCompensation"}
    if booleans:
        d.fmu.setBoolean([d.vr["reserveCompensation"]], [booleans["reserveCompensation"]])
    d.set(setpoint=setpoint, **reals)
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    return d


@pytest.mark.parametrize("zero", [TP1, 12.0, 60.0, 110.0])
def test_a_falling_step_is_the_filtered_transfer_functions_response(driver, zero):
    d = hub(driver, 95.0, reserveFilterZero=zero)
    assert d.get("current") == pytest.approx(K * 95.0, rel=1e-14)
    a = (zero - TP1) / (TP2 - TP1)
    t = 0.0
    for h in [0.5, 1.5, 3.0, 10.0, 45.0, 200.0]:
        d.step(h, setpoint=65.0)
        t += h
        want = K * 65.0 + K * 30.0 * (a * math.exp(-t / TP1) + (1.0 - a) * math.exp(-t / TP2))
        assert d.get("current") == pytest.approx(want, rel=1e-12), (zero, t)


def trajectory(driver, **reals):
    d = hub(driver, 70.0, **reals)
    out = []
    for k, u in enumerate([100.0, 62.0, 90.0, 60.0, 99.0] * 4):
        d.step(0.7 + 9.0 * (k % 3), setpoint=u)
        out.append(tuple(d.get("current", "hubEnergy", "hubH2Produced")))
    return out


def test_the_family_ends_at_plain_droop_and_compensation_bit_for_bit(driver):
    plain = trajectory(driver, powerReference=0.0)
    assert trajectory(driver, reserveFilterZero=TZ) == plain
    assert trajectory(driver, reserveFilterZero=TP2) == trajectory(driver, reserveCompensation=True)
    assert trajectory(driver, reserveFilterZero=40.0) != plain


@pytest.mark.parametrize(
    ("reals", "words"),
    [
        ({"reserveFilterZero": 1.0}, ["reserveFilterZero", "between the poles"]),
        ({"reserveFilterZero": 150.0}, ["reserveFilterZero", "113.568"]),
        ({"reserveFilterZero": 40.0, "reserveCompensation": True}, ["reserveFilterZero", "choose one"]),
        ({"reserveFilterZero": -3.0}, ["reserveFilterZero", ">= 0"]),
    ],
)
def test_a_zero_outside_the_poles_is_refused_by_name(driver, reals, words):
    d = driver(logging_on=True)
    with pytest.raises(FMICallException):
        initialise(d, 80.0, **reals)
    text = " ".join(message for _, _, message in d.messages)
    assert all(w in text for w in words), text
