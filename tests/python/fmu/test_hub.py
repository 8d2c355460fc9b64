"""The hub through fmpy: operating states, dispatch and power reference of the packaged FMU,
against closed-form expectations (steady states, transition times, N x one module)."""

import math

import numpy as np
import pytest

from conftest import PAPER, module_power

K, V0, R, C = PAPER["gain"], PAPER["voltageIntercept"], PAPER["ohmicResistance"], PAPER["h2Coefficient"]
COLD_START, WARM_START, START_POWER, STANDBY_POWER, STOP_DURATION = 300.0, 30.0, 300.0, 100.0, 60.0
IDLE, STARTING, RUNNING, STANDBY, STOPPING = range(5)


def hub(driver, setpoint=100.0, power=0.0, integers=None, booleans=None, **reals):
    """An initialised instance with Integer, Boolean and Real parameters set."""
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


def integers(d, *names):
    return d.fmu.getInteger([d.vr[n] for n in names])


def run(d, seconds, h, **inputs):
    if inputs:
        d.set(**inputs)
    for _ in range(round(seconds / h)):
        d.step(h)


def test_defaults_are_the_single_module(driver):
    d = hub(driver, setpoint=80.0)
    assert integers(d, "nModules", "dispatch", "belowMinimum", "operatingState", "modulesRunning") == [
        1,
        1,
        0,
        RUNNING,
        1,
    ]
    assert d.fmu.getBoolean([d.vr["powerInput"]]) == [False]
    assert d.get("hubPower") == d.get("power")
    assert d.get("hubPower") == pytest.approx(module_power(80.0), rel=1e-12)


def test_an_equal_hub_of_n_is_exactly_n_times_one_module(driver):
    n = 25_000
    big = hub(driver, setpoint=75.0, integers=dict(nModules=n, belowMinimum=1))
    one = hub(driver, setpoint=75.0)
    for u, seconds in [(95.0, 300), (62.0, 400), (100.0, 500), (70.0, 200)]:
        run(big, seconds, 2.0, setpoint=u)
        run(one, seconds, 2.0, setpoint=u)
        for name in ("hubPower", "hubH2Flow", "hubEnergy", "hubH2Produced"):
            assert big.get(name) == pytest.approx(n * one.get(name), rel=1e-12), name
        assert big.get("current") == pytest.approx(one.get("current"), rel=1e-12)
        assert big.get("voltage") == pytest.approx(one.get("voltage"), rel=1e-12)
        assert integers(big, "modulesRunning") == [n]
    assert big.get("runningHours") == pytest.approx(n * 1400 / 3600, rel=1e-12)
    assert big.get("hubH2MassFlow") == pytest.approx(big.get("hubH2Flow") * 2.01588e-3 / 22.413969, rel=1e-12)


@pytest.mark.parametrize("dispatch,below", [(1, 1), (2, 1), (2, 2), (3, 1)])
def test_a_hub_told_a_constant_power_draws_it_in_steady_state(driver, dispatch, below):
    n, target = 25_000, 45e6
    d = hub(
        driver,
        power=30e6,
        integers=dict(nModules=n, dispatch=dispatch, belowMinimum=below),
        booleans=dict(powerInput=True),
    )
    run(d, 3000, 10.0, powerReference=target)
    # The whole hub draws the reference: modules kept warm draw standbyPower, the running ones
    # the rest.
    assert d.get("hubPower") == pytest.approx(target, rel=1e-3)
    running = integers(d, "modulesRunning")[0]
    if dispatch == 1:
        assert running == n
    else:
        assert running == math.ceil(target / module_power(100.0))


def test_modules_kept_warm_draw_from_the_reference(driver):
    n = 1000
    d = hub(driver, power=2.0e6, integers=dict(nModules=n, dispatch=2, belowMinimum=1), booleans=dict(powerInput=True))
    run(d, 2400, 10.0, powerReference=1.0e6)  # about half the running modules go to standby
    running, standby = integers(d, "modulesRunning", "modulesStandby")
    assert standby > 300 and running + standby == math.ceil(2.0e6 / module_power(100.0))
    assert d.get("hubPower") == pytest.approx(1.0e6, rel=1e-9)
    # The running modules draw the reference less the standby power, shared equally.
    share = (1.0e6 - STANDBY_POWER * standby) / running
    assert d.get("voltage") * d.get("current") * n / running == pytest.approx(share, rel=1e-6)


def test_modules_held_warm_at_the_start_share_the_reference_and_start_warm(driver):
    n, warm, reference = 10, 3, 4 * module_power(100.0)
    d = hub(
        driver,
        power=reference,
        integers=dict(nModules=n, dispatch=2, belowMinimum=1, initialStandby=warm),
        booleans=dict(powerInput=True),
    )
    assert integers(d, "modulesRunning", "modulesStandby", "modulesIdle") == [4, warm, n - 4 - warm]
    # From the start the hub draws the reference; the running modules share what the warm
    # ones' standby power leaves, in steady state.
    share = (reference - warm * STANDBY_POWER) / 4
    current = (-V0 + math.sqrt(V0 * V0 + 4 * R * share)) / (2 * R)
    for _ in range(2):
        assert d.get("hubPower") == pytest.approx(reference, rel=1e-12)
        assert d.get("hubH2Flow") == pytest.approx(4 * C * current, rel=1e-12)
        run(d, 600, 10.0)
    # Asked for all of them: the warm modules run after warmStartTime, the idle after coldStartTime.
    run(d, WARM_START, 1.0, powerReference=n * module_power(100.0))
    assert integers(d, "modulesRunning", "modulesStarting") == [4 + warm, n - 4 - warm]
    run(d, COLD_START - WARM_START, 10.0)
    assert integers(d, "modulesRunning") == [n]


def test_sequential_dispatch_reaches_loads_an_equal_hub_cannot(driver):
    n = 1000
    seq = hub(driver, setpoint=20.0, integers=dict(nModules=n, dispatch=2, belowMinimum=2))
    equal = hub(
        driver, setpoint=20.0, integers=dict(nModules=n, dispatch=1, belowMinimum=0, spreadSeed=2), parameterSpread=0.0
    )
    # Sequential: 20 % of the hub is 200 modules at 100 %; equal with modules that never stop
    # keeps all 1000 at their 60 % minimum.
    assert integers(seq, "modulesRunning", "modulesIdle") == [200, 800]
    assert seq.get("hubH2Flow") == pytest.approx(200 * C * K * 100.0, rel=1e-12)
    assert equal.get("hubH2Flow") == pytest.approx(n * C * K * 60.0, rel=1e-12)


def test_stop_and_cold_start_follow_their_durations_exactly(driver):
    # One module that goes off below its minimum (a hub of one).
    d = hub(driver, setpoint=80.0, integers=dict(belowMinimum=2))
    run(d, 10, 1.0, setpoint=30.0)  # stop: blowdown for 60 s at standbyPower
    assert integers(d, "operatingState") == [STOPPING]
    assert d.get("hubPower") == STANDBY_POWER and d.get("current") == 0.0
    e0 = d.get("hubEnergy")
    run(d, 50, 5.0)
    assert integers(d, "operatingState") == [IDLE]
    assert d.get("hubEnergy") - e0 == pytest.approx(STANDBY_POWER * 50.0, rel=1e-12)
    run(d, 40, 8.0)  # idle: nothing drawn
    assert d.get("hubPower") == 0.0
    e1 = d.get("hubEnergy")
    assert e1 - e0 == pytest.approx(STANDBY_POWER * 50.0, rel=1e-12)
    # Run request: cold start for 300 s at startPower, then current at K * minSetpoint.
    run(d, 299, 13.0, setpoint=90.0)
    assert integers(d, "operatingState") == [STARTING] and d.get("hubPower") == START_POWER
    run(d, 1, 1.0)
    assert integers(d, "operatingState") == [RUNNING]
    assert d.get("current") == pytest.approx(K * 60.0, rel=1e-12)
    assert d.get("hubEnergy") - e1 == pytest.approx(START_POWER * COLD_START, rel=1e-12)
    assert d.get("starts") == 1.0


def test_standby_then_warm_start(driver):
    d = hub(driver, setpoint=80.0, integers=dict(belowMinimum=1))
    run(d, 100, 10.0, setpoint=0.0)
    assert integers(d, "operatingState") == [STANDBY] and d.get("hubPower") == STANDBY_POWER
    run(d, 30, 3.0, setpoint=70.0)
    assert integers(d, "operatingState") == [RUNNING]
    assert d.get("current") == pytest.approx(K * 60.0, rel=1e-12)
    assert d.get("starts") == 1.0
    assert d.get("runningHours") == pytest.approx(0.0, abs=1e-12)  # not a second of running yet


def power_schedule(t):
    """A power reference [W] stepping through sequential dispatch's thresholds every 600 s."""
    levels = [12e3, 3e3, 30e3, 500.0, 21e3, 8e3]
    return levels[min(int(t // 600), len(levels) - 1)]


@pytest.mark.parametrize("dispatch", [2, 3])
def test_results_at_common_points_do_not_depend_on_the_step_size(driver, dispatch):
    runs = {}
    for h in (0.5, 7.5, 60.0):
        d = hub(
            driver,
            power=power_schedule(0),
            integers=dict(nModules=12, dispatch=dispatch, belowMinimum=1),
            booleans=dict(powerInput=True),
        )
        rows = []
        for k in range(round(3600 / h)):
            d.set(powerReference=power_schedule(k * h))
            d.step(h)
            if (k + 1) * h % 60.0 == 0:
                rows.append(d.get("hubPower", "hubEnergy", "hubH2Produced", "runningHours", "starts"))
        runs[h] = np.array(rows)
    for h in (7.5, 60.0):
        np.testing.assert_allclose(runs[h], runs[0.5], rtol=1e-9, atol=1e-9)
    assert runs[0.5][-1, 4] > 0, "the schedule starts modules"


def test_hub_state_save_and_restore_replays_bit_identically(driver):
    d = hub(driver, power=15e3, integers=dict(nModules=12, dispatch=3, belowMinimum=1), booleans=dict(powerInput=True))
    run(d, 600, 10.0, powerReference=4e3)
    state = d.fmu.getFMUstate()
    blob = d.fmu.serializeFMUstate(state)

    def continuation():
        out = []
        for k in range(60):
            d.set(powerReference=power_schedule(600 * k / 10))
            d.step(10.0)
            out.append(d.get("hubPower", "hubEnergy", "starts"))
        return out

    t0 = d.time
    first = continuation()
    d.fmu.setFMUstate(d.fmu.deSerializeFMUstate(blob))
    d.time = t0
    assert continuation() == first
    d.fmu.freeFMUstate(state)


@pytest.mark.parametrize(
    "integers_,reals,words",
    [
        (dict(nModules=0), {}, "nModules"),
        (dict(nModules=5, dispatch=2), {}, "belowMinimum"),
        (dict(nModules=5, dispatch=4), {}, "dispatch"),
        (dict(nModules=5, belowMinimum=1), dict(standbyDuration=-1.0), "standbyDuration"),
        (dict(nModules=5), dict(parameterSpread=0.7), "parameterSpread"),
        (dict(nModules=5, dispatch=2, belowMinimum=1, initialStandby=6), {}, "initialStandby"),
        (dict(nModules=5, initialStandby=-1), {}, "initialStandby"),
    ],
)
def test_bad_hub_settings_are_refused_by_name(driver, integers_, reals, words):
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setInteger([d.vr[n] for n in integers_], list(integers_.values()))
    if reals:
        d.set(**reals)
    d.fmu.enterInitializationMode()
    with pytest.raises(Exception):
        d.fmu.exitInitializationMode()
    assert any(words in m for _, _, m in d.messages), d.messages


def test_a_hub_refuses_an_interpolated_input(driver):
    d = hub(driver, setpoint=80.0, integers=dict(nModules=3, belowMinimum=1))
    with pytest.raises(Exception):
        d.fmu.setRealInputDerivatives([d.vr["setpoint"]], [1], [0.5])
    assert any("holds its inputs" in m for _, _, m in d.messages)
    d.step(1.0)  # the instance still serves valid calls


def parameter_file(path, gains):
    """A parameter file as aem-identify writes it, one module per gain [A/%]."""
    import json

    modules = [
        {"module": f"M{k}", "parameters": {"gain": {"value": g, "unit": "A/%", "source": "identified"}}}
        for k, g in enumerate(gains)
    ]
    path.write_text(json.dumps({"generator": "test", "modules": modules}))
    return str(path)


def test_module_parameter_file_gives_modules_their_own_sets(driver, tmp_path):
    path = parameter_file(tmp_path / "params.json", [0.50, 0.56])
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setInteger([d.vr["nModules"]], [5])
    d.fmu.setString([d.vr["moduleParameterFile"]], [path])
    d.set(setpoint=80.0, ohmicResistance=0.2)  # parameters the file does not set keep these values
    d.fmu.enterInitializationMode()
    assert [s.decode() if isinstance(s, bytes) else s for s in d.fmu.getString([d.vr["moduleParameterFile"]])] == [path]
    d.fmu.exitInitializationMode()
    # Modules 0, 2, 4 have K = 0.50, modules 1, 3 have K = 0.56: I_k = K_k * 80 in steady state.
    currents = [0.50 * 80] * 3 + [0.56 * 80] * 2
    assert d.get("current") == pytest.approx(sum(currents) / 5, rel=1e-12)
    assert d.get("hubPower") == pytest.approx(sum((V0 + 0.2 * i) * i for i in currents), rel=1e-12)
    # The sets travel with the FMU state: the file is not read again.
    state = d.fmu.getFMUstate()
    blob = d.fmu.serializeFMUstate(state)
    run(d, 100, 10.0, setpoint=90.0)
    (tmp_path / "params.json").unlink()
    d.fmu.setFMUstate(d.fmu.deSerializeFMUstate(blob))
    assert d.get("current") == pytest.approx(sum(currents) / 5, rel=1e-12)
    d.fmu.freeFMUstate(state)


def test_a_relative_module_parameter_file_is_found_in_the_fmus_resources(fmu_path, model_description, tmp_path):
    """fmpy passes fmuResourceLocation as a percent-encoded file URI ("fmu%20dir%C3%BC"):
    the FMU decodes it and finds a relative moduleParameterFile in its resources folder."""
    from fmpy import extract
    from conftest import Driver

    unzipdir = tmp_path / "fmu dirü"
    extract(str(fmu_path), str(unzipdir))
    (unzipdir / "resources").mkdir(exist_ok=True)
    parameter_file(unzipdir / "resources" / "modules.json", [0.50, 0.56])
    d = Driver(str(unzipdir), model_description, logging_on=True)
    try:
        d.fmu.setupExperiment(startTime=0.0)
        d.fmu.setInteger([d.vr["nModules"]], [2])
        d.fmu.setString([d.vr["moduleParameterFile"]], ["modules.json"])
        d.set(setpoint=80.0)
        d.fmu.enterInitializationMode()
        d.fmu.exitInitializationMode()
        assert d.get("current") == pytest.approx((0.50 + 0.56) * 80 / 2, rel=1e-12)
    finally:
        d.free()


def test_a_relative_module_parameter_file_that_is_nowhere_says_where_it_was_looked_for(driver, unzipdir):
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setString([d.vr["moduleParameterFile"]], ["no-such-modules.json"])
    d.fmu.enterInitializationMode()
    with pytest.raises(Exception):
        d.fmu.exitInitializationMode()
    assert any("no-such-modules.json" in m and "resources folder" in m for _, _, m in d.messages), d.messages


@pytest.mark.parametrize(
    "content,words",
    [
        (None, "moduleParameterFile"),  # missing file
        (
            '{"generator": "x", "modules": [{"module": "A", "parameters": {"gain": {"value": 0.5, "unit": "A", "source": "identified"}}}]}',
            "unit",
        ),
        (
            '{"generator": "x", "modules": [{"module": "A", "parameters": {"tauPole1": {"value": -1, "unit": "s", "source": "identified"}}}]}',
            "tauPole1",
        ),
    ],
)
def test_a_bad_module_parameter_file_is_refused_by_name(driver, tmp_path, content, words):
    path = tmp_path / "params.json"
    if content is not None:
        path.write_text(content)
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.setString([d.vr["moduleParameterFile"]], [str(path)])
    d.fmu.enterInitializationMode()
    with pytest.raises(Exception):
        d.fmu.exitInitializationMode()
    assert any(words in m and "params.json" in m for _, _, m in d.messages), d.messages
