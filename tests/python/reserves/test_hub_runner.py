"""The prequalification's hub runner steps the packaged FMU in native code (aem_drive): the same
FMI calls as a plain fmpy master makes through fmpy's own wrappers, so the same bits; a refusal
in the middle of a signal names the step and says the FMU's words."""

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from aem_electrolyser.hub.messages import FmuError
from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, signals
from aem_electrolyser.reserves.signals import DOWN, UP

N = 100


def fmpy_master(fmu_path, hub, runner, t, driven, values, parameters):
    """A plain master on fmpy's FMU2Slave: the hub set up as HubRunner sets it up, then at every
    t[k] the input set, the outputs read, one step to t[k+1]."""
    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=extract(str(fmu_path)),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="reference",
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=float(t[0]))
    fmu.setInteger(
        [vr["nModules"], vr["dispatch"], vr["belowMinimum"]], [hub.n_modules, hub.dispatch, hub.below_minimum]
    )
    fmu.setBoolean([vr["powerInput"], vr["reserveCompensation"]], [True, hub.compensation])
    reals = dict(parameters)
    if hub.filter_zero > 0:
        reals["reserveFilterZero"] = hub.filter_zero
    reals["powerReference"] = runner.baseline
    reals[driven] = float(values[0])
    fmu.setReal([vr[n] for n in reals], list(reals.values()))
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    out = np.empty((len(t), 2))
    for k in range(len(t)):
        fmu.setReal([vr[driven]], [float(values[k])])
        out[k] = fmu.getReal([vr["hubPower"], vr["reserveRequest"]])
        if k + 1 < len(t):
            fmu.doStep(float(t[k]), float(t[k + 1] - t[k]))
    fmu.terminate()
    fmu.freeInstance()
    return out[:, 0], out[:, 1]


@pytest.mark.parametrize(
    "hub, test",
    [
        (Hub(N, dispatch=2, below_minimum=1, baseline=0.5, filter_zero=64.5), "FCR-D up ramp"),
        (Hub(N, baseline=0.8, compensation=True), "FCR-D down sine, 15 s"),
        (Hub(N, dispatch=2, below_minimum=1, baseline=0.35), "aFRR down step"),
    ],
)
def test_the_native_steps_give_the_bits_of_a_plain_fmpy_master(fmu_path, hub, test):
    runner = HubRunner(fmu_path, hub)
    try:
        capacity = 0.1 * runner.rated_power
        if test == "FCR-D up ramp":
            signal, parameters = signals.fcr_d_ramp(UP, 0.1), {"fcrDUpCapacity": capacity}
        elif test.startswith("FCR-D down sine"):
            signal = signals.sine_test("FCR-D down", 15.0, assess.sine_step(15.0, 0.1))
            parameters = {"fcrDDownCapacity": capacity}
        else:
            signal, parameters = signals.frr_step("aFRR", DOWN, 0.1), {}
        if signal.f is not None:
            driven, values = "frequency", np.asarray(signal.f, float)
            power, request = runner.run(signal.t, frequency=values, parameters=parameters)
        else:
            driven, values = "powerReference", runner.baseline - np.asarray(signal.request) * capacity
            power, request = runner.run(signal.t, power_reference=values, parameters=parameters)
        expected_power, expected_request = fmpy_master(fmu_path, hub, runner, signal.t, driven, values, parameters)
    finally:
        runner.close()
    assert len(power) == len(signal.t) > 1000
    assert np.ptp(power) > 0.01 * capacity  # the test moves the hub
    assert np.array_equal(power.view(np.uint64), expected_power.view(np.uint64)), test
    assert np.array_equal(request.view(np.uint64), expected_request.view(np.uint64)), test


def test_a_refusal_halfway_names_the_step_and_the_fmus_words(fmu_path):
    """A NaN frequency at t = 2 s: the FMU refuses fmi2SetReal; the run stops there."""
    runner = HubRunner(fmu_path, Hub(N, baseline=0.8))
    t = np.arange(0.0, 5.0, 0.1)
    f = np.full(t.size, 50.0)
    f[20:] = np.nan
    try:
        with pytest.raises(FmuError) as refused:
            runner.run(t, frequency=f, parameters={"fcrDUpCapacity": 1e3})
    finally:
        runner.close()
    said = str(refused.value)
    assert f"the step at t = {t[20]} s" in said and "frequency" in said, said


def test_a_signal_and_times_of_different_lengths_are_refused_before_any_step(fmu_path):
    runner = HubRunner(fmu_path, Hub(N, baseline=0.8))
    try:
        with pytest.raises(ValueError, match="9 values for 10 time points"):
            runner.run(np.arange(10.0), frequency=np.full(9, 50.0))
    finally:
        runner.close()
