"""Ageing through fmpy: off by default, the drift and its energy in closed form for a module and
a hub, recovery at rest, step-size independence, state save and restore, and refused values.

The drift d [V] adds to the stack voltage, V = V0 + R I + d, with d = d_irr + d_rev:
d_irr = d0 + rho * (hours Steady) + delta * starts, and d_rev builds up while Steady,
tau_b d(d_rev)/dt = A - d_rev, and recovers otherwise, tau_r d(d_rev)/dt = -d_rev. Every
expectation here is written out from these equations, not read from the FMU.
"""

import math

import pytest
from fmpy.fmi1 import FMICallException

from conftest import PAPER

K, V0, R = PAPER["gain"], PAPER["voltageIntercept"], PAPER["ohmicResistance"]
AGEING = {
    "initialVoltageDrift": 0.02,  # V: an aged stack
    "driftPerRunningHour": 1e-3,  # V/h
    "driftPerStart": 5e-3,  # V
    "reversibleDrift": 0.3,  # V
    "driftBuildUpTime": 1800.0,  # s
    "driftRecoveryTime": 900.0,  # s
}


def drift_while_running(t, p=AGEING):
    """d(t) of a module Steady from the start [V]."""
    a, tau = p["reversibleDrift"], p["driftBuildUpTime"]
    return p["initialVoltageDrift"] + p["driftPerRunningHour"] * t / 3600.0 + a * (1.0 - math.exp(-t / tau))


def drift_integral(t, p=AGEING):
    """The integral of d over [0, t] of a module Steady from the start [V s]."""
    a, tau, rho = p["reversibleDrift"], p["driftBuildUpTime"], p["driftPerRunningHour"] / 3600.0
    return (p["initialVoltageDrift"] + a) * t + 0.5 * rho * t * t - a * tau * (1.0 - math.exp(-t / tau))


def test_off_by_default_nothing_drifts(driver):
    d = driver().initialize(setpoint=80.0)
    for _ in range(10):
        d.step(60.0, setpoint=95.0)
    assert d.get("voltageDrift", "maxVoltageDrift") == [0.0, 0.0]
    i = d.get("current")
    assert d.get("voltage") == pytest.approx(V0 + R * i, rel=1e-15)


@pytest.mark.parametrize("n_modules", [1, 25])
def test_a_steady_plant_drifts_and_draws_in_closed_form(driver, n_modules):
    d = driver()
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setInteger([d.vr["nModules"], d.vr["belowMinimum"]], [n_modules, 1 if n_modules > 1 else 0])
    d.set(setpoint=80.0, **AGEING)
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    i = K * 80.0
    assert d.get("voltageDrift") == pytest.approx(0.02, rel=1e-15)
    t = 0.0
    for h in [1.0, 59.0, 600.0, 2940.0, 3600.0]:
        d.step(h)
        t += h
        drift = drift_while_running(t)
        assert d.get("voltageDrift", "maxVoltageDrift") == pytest.approx([drift, drift], rel=1e-13)
        assert d.get("voltage") == pytest.approx(V0 + R * i + drift, rel=1e-14)
        assert d.get("power") == pytest.approx((V0 + R * i + drift) * i, rel=1e-14)
        energy = (V0 + R * i) * i * t + i * drift_integral(t)
        assert d.get("energy") == pytest.approx(energy, rel=1e-12)
        assert d.get("hubEnergy") == pytest.approx(n_modules * energy, rel=1e-12)


def test_a_stopped_module_recovers_and_a_start_adds_its_rise(driver):
    d = driver()
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setInteger([d.vr["nModules"], d.vr["belowMinimum"]], [2, 2])
    d.set(setpoint=80.0, coldStartTime=300.0, **AGEING)
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    for _ in range(30):
        d.step(60.0)
    built = drift_while_running(1800.0)
    assert d.get("voltageDrift") == pytest.approx(built, rel=1e-13)
    # Stopped for 30 min (blowdown, then idle): the reversible part falls with tau_r.
    for _ in range(30):
        d.step(60.0, setpoint=0.0)
    reversible = 0.3 * (1.0 - math.exp(-1.0)) * math.exp(-2.0)
    irreversible = 0.02 + 1e-3 * 0.5
    assert d.get("voltageDrift") == pytest.approx(irreversible + reversible, rel=1e-13)
    # Both restart: one start each adds 5 mV; starting is not running, so it recovers on.
    d.step(300.0, setpoint=80.0)
    assert d.get("starts") == 2.0
    want = irreversible + 5e-3 + reversible * math.exp(-300.0 / 900.0)
    assert d.get("voltageDrift", "maxVoltageDrift") == pytest.approx([want, want], rel=1e-13)


def run_wind(driver, h, hours=3.0):
    """A sequential hub of 8 under a changing power reference (held for 10 min at a time)."""
    d = driver()
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setInteger([d.vr["nModules"], d.vr["dispatch"], d.vr["belowMinimum"]], [8, 2, 1])
    d.fmu.setBoolean([d.vr["powerInput"]], [True])
    d.set(powerReference=10_000.0, **AGEING)
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    for k in range(round(hours * 3600.0 / h)):
        t = math.floor(k * h / 600.0) * 600.0
        d.set(powerReference=10_000.0 + 8_000.0 * math.sin(t / 1500.0))
        d.step(h)
    return d.get("hubEnergy", "voltageDrift", "maxVoltageDrift", "starts")


def test_a_drifting_hub_does_not_depend_on_the_step_size(driver):
    reference = run_wind(driver, 600.0)
    assert reference[3] > 0.0, "modules started and stopped"
    assert reference[2] > reference[1], "the modules drifted apart"
    for h in [2.0, 30.0]:
        assert run_wind(driver, h) == pytest.approx(reference, rel=1e-11)


def test_a_restored_state_continues_the_drift_bit_for_bit(driver):
    d = driver()
    d.fmu.setupExperiment(startTime=0.0)
    d.set(setpoint=70.0, **AGEING)
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    for _ in range(20):
        d.step(60.0, setpoint=90.0)
    blob = d.fmu.serializeFMUstate(d.fmu.getFMUstate())
    time = d.time
    d.step(600.0)
    after = d.get("energy", "voltageDrift")
    d.fmu.setFMUstate(d.fmu.deSerializeFMUstate(blob))
    d.time = time
    d.step(600.0)
    assert d.get("energy", "voltageDrift") == after


@pytest.mark.parametrize(
    ("name", "value"),
    [("driftRecoveryTime", 0.0), ("reversibleDrift", -0.1), ("initialVoltageDrift", float("nan"))],
)
def test_bad_ageing_values_are_refused_by_name(driver, name, value):
    """Refused when set (a NaN) or at the end of initialisation, naming the parameter."""
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException):
        d.set(**{name: value})
        d.fmu.enterInitializationMode()
        d.fmu.exitInitializationMode()
    assert any(name in message for _, _, message in d.messages), d.messages
