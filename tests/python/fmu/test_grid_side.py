"""The grid side through fmpy: supply losses and auxiliaries, off by default.

A module's supply loses P0 + Vs I + Rs I^2 while the stack carries current I, and its balance
of plant draws P_aux while it starts or runs; the grid sees

    acPower = power + P0 + Vs I + Rs I^2 + P_aux        (running, I = K u in steady state)

Every expectation is written out from these equations and Table I, not read from the FMU; the
grid energy is checked against the closed form at constant current and against step-size
independence while the current moves.
"""

import pytest
from fmpy.fmi1 import FMICallException

from conftest import PAPER, WORKED_EXAMPLE

K, V0, R = PAPER["gain"], PAPER["voltageIntercept"], PAPER["ohmicResistance"]
#: Assumed losses of a 2.4 kW module's supply and balance of plant (test values).
LOSSES = {
    "auxiliaryPower": 150.0,
    "supplyNoLoadLoss": 40.0,
    "supplyLossVoltage": 0.8,
    "supplyLossResistance": 0.002,
}


def steady_grid_power(u):
    """One running module's grid power at setpoint u [%] in steady state [W]."""
    i = K * u
    p = LOSSES
    return (
        (V0 + R * i) * i
        + p["supplyNoLoadLoss"]
        + p["supplyLossVoltage"] * i
        + p["supplyLossResistance"] * i * i
        + p["auxiliaryPower"]
    )


def instance(driver, setpoint=80.0, power=0.0, integers=None, booleans=None, **reals):
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    for name, value in (integers or {}).items():
        d.fmu.setInteger([d.vr[name]], [value])
    for name, value in (booleans or {}).items():
        d.fmu.setBoolean([d.vr[name]], [value])
    d.set(setpoint=setpoint, powerReference=power, **reals)
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    return d


def test_by_default_the_grid_sees_the_electric_power(driver):
    d = instance(driver, setpoint=70.0, integers=dict(nModules=5, dispatch=2, belowMinimum=1))
    assert d.get(*LOSSES) == [0.0, 0.0, 0.0, 0.0]
    assert d.fmu.getBoolean([d.vr["gridSideReference"]]) == [False]
    for setpoint in (100.0, 20.0, 65.0, 90.0):
        for _ in range(20):
            d.step(30.0, setpoint=setpoint)
            assert d.get("acPower", "hubAcPower", "hubAcEnergy") == d.get("power", "hubPower", "hubEnergy")


def test_a_steady_module_draws_the_closed_form_grid_power_and_energy(driver):
    d = instance(driver, setpoint=80.0, **LOSSES)
    want = steady_grid_power(80.0)
    assert d.get("acPower") == pytest.approx(want, rel=1e-13)
    assert d.get("hubAcPower") == pytest.approx(want, rel=1e-13)
    assert d.get("power") == pytest.approx((V0 + R * K * 80.0) * K * 80.0, rel=1e-13)
    for _ in range(6):
        d.step(600.0)
    assert d.get("hubAcEnergy") == pytest.approx(want * 3600.0, rel=1e-10)


def test_the_grid_energy_does_not_depend_on_the_step_size(driver):
    """From 60 % to 100 % (ramp-limited rise) on a hub of 3: the grid energy after 600 s is the
    same whatever the master's step."""

    def energy(h):
        d = instance(driver, setpoint=60.0, integers=dict(nModules=3, belowMinimum=1), **LOSSES)
        d.set(setpoint=100.0)
        for _ in range(round(600.0 / h)):
            d.step(h)
        return d.get("hubAcEnergy", "hubEnergy")

    reference = energy(600.0)
    assert reference[0] - reference[1] > 3 * 600.0 * 190.0, "losses and auxiliaries are drawn"
    for h in (0.5, 7.5, 60.0):
        got = energy(h)
        assert got[0] == pytest.approx(reference[0], rel=1e-11), h


def test_a_grid_side_power_reference_is_what_the_grid_draws(driver):
    reference = 10 * steady_grid_power(75.0)
    d = instance(
        driver,
        power=reference,
        integers=dict(nModules=10, belowMinimum=1),
        booleans=dict(powerInput=True, gridSideReference=True),
        **LOSSES,
    )
    assert d.get("hubAcPower") == pytest.approx(reference, rel=1e-12)
    assert d.get("current") == pytest.approx(K * 75.0, rel=1e-12)
    stack_side = instance(
        driver,
        power=reference,
        integers=dict(nModules=10, belowMinimum=1),
        booleans=dict(powerInput=True),
        **LOSSES,
    )
    assert stack_side.get("hubPower") == pytest.approx(reference, rel=1e-12)
    assert stack_side.get("hubAcPower") > reference


def test_a_restored_state_continues_the_same_grid_energy(driver):
    d = instance(driver, setpoint=65.0, integers=dict(nModules=4, dispatch=2, belowMinimum=1), **LOSSES)
    d.step(120.0, setpoint=90.0)
    state = d.fmu.getFMUstate()
    blob = d.fmu.serializeFMUstate(state)
    d.fmu.freeFMUstate(state)
    d.step(500.0, setpoint=30.0)
    after = d.get("hubAcEnergy", "hubAcPower")
    state = d.fmu.deSerializeFMUstate(blob)
    d.fmu.setFMUstate(state)
    d.fmu.freeFMUstate(state)
    d.time = 120.0
    d.step(500.0, setpoint=30.0)
    assert d.get("hubAcEnergy", "hubAcPower") == after


@pytest.mark.parametrize("name", list(LOSSES))
def test_a_negative_loss_refuses_initialisation_with_its_name(driver, name):
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.set(**{name: -1.0})
    d.fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        d.fmu.exitInitializationMode()
    assert any(status == "ERROR" and name in text for status, _, text in d.messages), d.messages


@pytest.mark.parametrize(
    "setpoint, ac_power, grid_kwh_per_kg", [(60.0, 1517, 54.7), (80.0, 2039, 55.2), (100.0, 2600, 56.3)]
)
def test_the_worked_example_of_the_model_page(driver, setpoint, ac_power, grid_kwh_per_kg):
    """docs/model.md's worked example (socket sizes of Enapter's handbook, an assumed supply)."""
    d = instance(driver, setpoint=setpoint, **WORKED_EXAMPLE)
    assert round(d.get("acPower")) == ac_power
    assert round(d.get("acPower") / 1000.0 / d.get("hubH2MassFlow"), 1) == grid_kwh_per_kg
