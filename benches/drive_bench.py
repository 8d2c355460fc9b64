"""Benchmark: the prequalification's hub runner (the steps in native code, aem_drive) against a
plain fmpy master making the same FMI calls from Python (FMU2Slave: setReal, getReal, doStep per
step), on upward FCR-D's tests for a 25 000-module equal hub: the ramp test and the seven sine
tests (57 858 steps). Prints seconds per capacity tested and the ratio, same run, best of three.
Run by scripts/bench.sh after packaging the FMU."""

import time

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from aem_electrolyser import fmu_path
from aem_electrolyser.cli import quiet_on_closed_stdout
from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, signals

FMU = fmu_path()
HUB = Hub(25_000, baseline=0.8)
PRODUCT = "FCR-D up"


def tests():
    """The ramp test and the sine tests of upward FCR-D, as the prequalification runs them."""
    found = [signals.fcr_d_ramp(signals.UP, 0.1)]
    for period in signals.sine_periods(PRODUCT):
        found.append(signals.sine_test(PRODUCT, period, assess.sine_step(period, 0.1)))
    return found


def fmpy_loop(unzipped, md, vr, parameters, runner, signal):
    fmu = FMU2Slave(
        guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench"
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=float(signal.t[0]))
    fmu.setInteger([vr["nModules"], vr["dispatch"], vr["belowMinimum"]], [HUB.n_modules, HUB.dispatch, 0])
    fmu.setBoolean([vr["powerInput"]], [True])
    reals = {**parameters, "powerReference": runner.baseline, "frequency": float(signal.f[0])}
    fmu.setReal([vr[n] for n in reals], list(reals.values()))
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    t, f = signal.t, signal.f
    power = np.empty(len(t))
    for k in range(len(t)):
        fmu.setReal([vr["frequency"]], [float(f[k])])
        power[k] = fmu.getReal([vr["hubPower"], vr["reserveRequest"]])[0]
        if k + 1 < len(t):
            fmu.doStep(float(t[k]), float(t[k + 1] - t[k]))
    fmu.terminate()
    fmu.freeInstance()
    return power


def best_of_three(work):
    times = []
    for _ in range(3):
        start = time.perf_counter()
        result = work()
        times.append(time.perf_counter() - start)
    return min(times), result


def main():
    md = read_model_description(str(FMU))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(str(FMU))
    runner = HubRunner(FMU, HUB)
    signals_ = tests()
    parameters = {"fcrDUpCapacity": 0.05 * runner.rated_power}
    steps = sum(len(s.t) for s in signals_)
    try:
        native, ours = best_of_three(
            lambda: [runner.run(s.t, frequency=s.f, parameters=parameters)[0] for s in signals_]
        )
        plain, theirs = best_of_three(lambda: [fmpy_loop(unzipped, md, vr, parameters, runner, s) for s in signals_])
    finally:
        runner.close()
    same = all(np.array_equal(a, b) for a, b in zip(ours, theirs))
    print(
        f"upward FCR-D's tests, {HUB.n_modules} modules, {steps} steps: hub runner (aem_drive) {native:.3f} s, "
        f"fmpy master {plain:.3f} s: {plain / native:.1f}x faster; the same bits: {same}"
    )


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
