"""The stack temperature through fmpy: off by default, closed-form warm-up and held setpoint,
step-size independence, state save and restore, and refused values.

Heat balance of one module (thermalModel = true), T the stack temperature [K]:

    V = V0 + kV (T - Tn) + (R + kR (T - Tn)) I
    C dT/dt = (V - n 1.481 V) I - (T - Ta)/Rth - Qc

with an ideal thermostat: Qc = 0 below the setpoint Ts, the surplus heat at Ts while that is
within [0, Qmax], Qmax above. At constant current the balance is linear in T, so a warm-up is
an exponential toward the temperature where heat equals loss; every expectation here is written
out from these equations, not read from the FMU.
"""

import math

import pytest
from fmpy.fmi1 import FMICallException

from conftest import PAPER

K, V0, R = PAPER["gain"], PAPER["voltageIntercept"], PAPER["ohmicResistance"]
#: The FMU's thermal start values (modelDescription.xml), written here as the test's inputs.
THERMAL = {
    "initialTemperature": 288.15,
    "heatCapacity": 25_000.0,
    "thermalResistance": 0.2,
    "coolingSetpoint": 328.15,
    "maxCoolingPower": 1000.0,
    "nominalTemperature": 328.15,
    "voltageTemperatureCoefficient": -0.046,
    "resistanceTemperatureCoefficient": -0.0015,
}
N_CELLS = 23
THERMONEUTRAL = 1.481


def thermal(driver, setpoint, ambient=288.15, **overrides):
    """An initialised instance with the thermal model on."""
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setBoolean([d.vr["thermalModel"]], [True])
    d.set(setpoint=setpoint, ambientTemperature=ambient, **{**THERMAL, **overrides})
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    return d


def linear_balance(current, ambient, p=THERMAL, cooling=0.0):
    """(a, b) of dT/dt = a T + b at constant current [A], from the balance written out."""
    kv, kr, tn = p["voltageTemperatureCoefficient"], p["resistanceTemperatureCoefficient"], p["nominalTemperature"]
    heat_per_kelvin = (kv + kr * current) * current  # d(heat)/dT [W/K]
    heat_at_tn = (V0 + R * current - N_CELLS * THERMONEUTRAL) * current  # [W]
    c = p["heatCapacity"]
    a = (heat_per_kelvin - 1.0 / p["thermalResistance"]) / c
    b = (heat_at_tn - heat_per_kelvin * tn + ambient / p["thermalResistance"] - cooling) / c
    return a, b


def test_off_by_default_the_stack_is_at_the_curves_temperature(driver):
    d = driver().initialize(setpoint=80.0)
    assert d.fmu.getBoolean([d.vr["thermalModel"]]) == [False]
    for _ in range(10):
        d.step(30.0, setpoint=95.0)
    assert d.get("stackTemperature", "coolingPower") == [328.15, 0.0]
    i = d.get("current")
    assert d.get("voltage") == pytest.approx(V0 + R * i, rel=1e-15)


def test_a_cold_start_warms_exponentially_then_holds_the_setpoint(driver):
    d = thermal(driver, setpoint=60.0)
    current = K * 60.0
    a, b = linear_balance(current, 288.15)
    t_inf = -b / a
    assert t_inf > THERMAL["coolingSetpoint"], "this stack reaches the setpoint at 60 %"
    t0 = THERMAL["initialTemperature"]
    kv, kr = THERMAL["voltageTemperatureCoefficient"], THERMAL["resistanceTemperatureCoefficient"]
    cold_voltage = V0 + kv * (t0 - 328.15) + (R + kr * (t0 - 328.15)) * current
    assert d.get("voltage") == pytest.approx(cold_voltage, rel=1e-14)
    # Warming: T(t) = T_inf + (T0 - T_inf) e^(a t), until it reaches Ts.
    reach = math.log((THERMAL["coolingSetpoint"] - t_inf) / (t0 - t_inf)) / a
    for _ in range(int(reach // 600)):
        d.step(600.0)
        expected = t_inf + (t0 - t_inf) * math.exp(a * d.time)
        assert d.get("stackTemperature") == pytest.approx(expected, abs=1e-7), f"t = {d.time} s"
        assert d.get("coolingPower") == 0.0
    # Then held at Ts, the cooling taking the surplus (heat at Ts minus the loss to ambient).
    d.step(math.ceil(reach / 600) * 600 - d.time + 600.0)
    surplus = (V0 + R * current - N_CELLS * THERMONEUTRAL) * current - (328.15 - 288.15) / 0.2
    assert d.get("stackTemperature") == 328.15
    assert d.get("coolingPower") == pytest.approx(surplus, rel=1e-12)
    # coolingPower follows the ambient input at once (direct feedthrough).
    # A warmer ambient takes less heat away: 10 K / Rth more to cool.
    d.set(ambientTemperature=298.15)
    assert d.get("coolingPower") == pytest.approx(surplus + 10.0 / 0.2, rel=1e-12)
    # A colder one takes more than the surplus: the cooling stops (the stack will cool).
    d.set(ambientTemperature=268.15)
    assert surplus - 20.0 / 0.2 < 0.0
    assert d.get("coolingPower") == 0.0


def test_the_stack_temperature_does_not_depend_on_the_step_size(driver):
    """The same setpoint program at 1 ms, 0.1 s, 7.5 s and 60 s steps: equal at every minute
    within 1e-6 K (a small stack, 40 s time constant, so the current's transients matter)."""

    def minutes(h, n_minutes):
        d = thermal(driver, setpoint=60.0, ambient=268.15, heatCapacity=200.0, maxCoolingPower=150.0)
        out = []
        per = round(60.0 / h)
        for m in range(n_minutes):
            setpoint = 100.0 if m % 2 == 0 else 60.0
            for _ in range(per):
                d.step(h, setpoint=setpoint)
            out.append(d.get("stackTemperature"))
        return out

    reference = minutes(60.0, 6)
    assert max(reference) - min(reference) > 5.0, "the program moves the temperature"
    for h, n in [(1e-3, 2), (0.1, 6), (7.5, 6)]:
        got = minutes(h, n)
        for k, (t, r) in enumerate(zip(got, reference)):
            assert abs(t - r) < 1e-6, f"h = {h} s, minute {k + 1}: {t} K vs {r} K"


def test_a_restored_state_continues_the_same_temperature(driver):
    d = thermal(driver, setpoint=90.0)
    for _ in range(5):
        d.step(60.0)
    state = d.fmu.getFMUstate()
    blob = d.fmu.serializeFMUstate(state)
    d.fmu.freeFMUstate(state)
    d.step(300.0, setpoint=70.0)
    after = d.get("stackTemperature", "voltage", "energy")
    d.set(setpoint=90.0)
    state = d.fmu.deSerializeFMUstate(blob)
    d.fmu.setFMUstate(state)
    d.fmu.freeFMUstate(state)
    d.time = 300.0
    assert d.get("stackTemperature") < after[0]
    d.step(300.0, setpoint=70.0)
    assert d.get("stackTemperature", "voltage", "energy") == after


@pytest.mark.parametrize(
    "name, value, words",
    [
        ("heatCapacity", -1.0, "heatCapacity"),
        ("thermalResistance", 0.0, "thermalResistance"),
        ("initialTemperature", -3.0, "initialTemperature"),
        ("maxCoolingPower", -10.0, "maxCoolingPower"),
        ("standbyHeaterPower", -5.0, "standbyHeaterPower"),
    ],
)
def test_bad_thermal_parameters_refuse_initialisation_with_their_name(driver, name, value, words):
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setBoolean([d.vr["thermalModel"]], [True])
    d.set(**{name: value})
    d.fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        d.fmu.exitInitializationMode()
    assert any(status == "ERROR" and words in text for status, _, text in d.messages), d.messages


def test_a_hub_of_equal_modules_is_that_many_thermal_modules(driver):
    """nModules = 4, equal dispatch, never stopping: the per-module outputs of the hub are the
    single thermal module's, the hub's energy four times its energy."""
    one = thermal(driver, setpoint=70.0)
    hub = driver(logging_on=True)
    hub.fmu.setupExperiment(startTime=0.0)
    hub.fmu.setBoolean([hub.vr["thermalModel"]], [True])
    hub.fmu.setInteger([hub.vr["nModules"]], [4])
    hub.set(setpoint=70.0, ambientTemperature=288.15, **THERMAL)
    hub.fmu.enterInitializationMode()
    hub.fmu.exitInitializationMode()
    for setpoint in (100.0, 60.0, 85.0):
        one.step(900.0, setpoint=setpoint)
        hub.step(900.0, setpoint=setpoint)
        t, q, v = one.get("stackTemperature", "coolingPower", "voltage")
        assert hub.get("stackTemperature") == pytest.approx(t, abs=1e-12)
        assert hub.get("coolingPower") == pytest.approx(q, abs=1e-9)
        assert hub.get("voltage") == pytest.approx(v, rel=1e-14)
        assert hub.get("hubEnergy") == pytest.approx(4.0 * one.get("energy"), rel=1e-12)


def test_a_stopped_hub_module_cools_toward_ambient(driver):
    """One module of a hub (belowMinimum = off) asked for nothing stops and cools: from the
    setpoint, C dT/dt = -(T - Ta)/Rth, an exponential with the time constant Rth C."""
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setBoolean([d.vr["thermalModel"]], [True])
    d.fmu.setInteger([d.vr["nModules"], d.vr["belowMinimum"]], [2, 2])
    d.set(setpoint=0.0, ambientTemperature=278.15, **{**THERMAL, "initialTemperature": 328.15})
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    tau = THERMAL["thermalResistance"] * THERMAL["heatCapacity"]
    for _ in range(6):
        d.step(1200.0)
        expected = 278.15 + 50.0 * math.exp(-d.time / tau)
        assert d.get("stackTemperature") == pytest.approx(expected, abs=1e-9)
    assert d.fmu.getInteger([d.vr["modulesIdle"]]) == [2]


@pytest.mark.parametrize("ambient", [float("nan"), 0.0, -20.0, float("inf")])
def test_a_bad_ambient_temperature_is_refused_and_the_instance_goes_on(driver, ambient):
    d = thermal(driver, setpoint=80.0)
    d.step(120.0)
    before = d.get("stackTemperature", "coolingPower", "energy")
    with pytest.raises(FMICallException):
        d.set(ambientTemperature=ambient)
    assert any(status == "ERROR" and "ambientTemperature" in text for status, _, text in d.messages)
    assert d.get("stackTemperature", "coolingPower", "energy") == before
    twin = thermal(driver, setpoint=80.0)
    twin.step(120.0)
    d.step(60.0)
    twin.step(60.0)
    assert d.get("stackTemperature", "energy") == twin.get("stackTemperature", "energy")


def test_a_standby_heater_holds_the_hub_at_the_setpoint_and_draws_the_loss(driver):
    """Two modules go to standby at 55 degC in 5 degC air with a 400 W heater each: the heater
    makes up the loss (Ts - Ta)/Rth = 250 W, drawn on top of standbyPower, and the stack stays
    at the setpoint; the energy is the constant draw times the time."""
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setBoolean([d.vr["thermalModel"]], [True])
    d.fmu.setInteger([d.vr["nModules"], d.vr["dispatch"], d.vr["belowMinimum"]], [2, 2, 1])
    d.set(
        setpoint=80.0,
        ambientTemperature=278.15,
        standbyDuration=36_000.0,
        standbyHeaterPower=400.0,
        **{**THERMAL, "initialTemperature": 328.15},
    )
    d.fmu.enterInitializationMode()
    d.fmu.exitInitializationMode()
    hold = (328.15 - 278.15) / THERMAL["thermalResistance"]
    standby = d.get("standbyPower")
    d.step(1e-9, setpoint=0.0)
    e0 = d.get("hubEnergy")
    for _ in range(6):
        d.step(600.0)
        assert d.fmu.getInteger([d.vr["modulesStandby"]]) == [2]
        assert d.get("stackTemperature") == 328.15
        assert d.get("hubPower") == pytest.approx(2 * (standby + hold), rel=1e-12)
    assert d.get("hubEnergy") - e0 == pytest.approx(2 * (standby + hold) * 3600.0, rel=1e-9)
    # Held at 55 degC, both restart warm (in warmStartTime).
    d.step(d.get("warmStartTime"), setpoint=80.0)
    assert d.fmu.getInteger([d.vr["modulesRunning"]]) == [2]
    assert d.get("starts", "warmStarts") == [2.0, 2.0]
