#!/usr/bin/env python3
"""Benchmark through fmpy, beside the Rust figures and the Python/SciPy peer (one run).

    python benches/fmpy_bench.py [--rust target/bench/rust.json] [--fmu target/fmu/AemElectrolyser.fmu]

Prints: µs per fmi2SetReal + fmi2DoStep + fmi2GetReal(4 outputs) through fmpy for one day at
1 s, the FMU's own share of that call (ns per step of the same three calls made in process
by the Rust benchmark, read from --rust), and the wall time of the same day simulated by a
straightforward Python/SciPy implementation (benches/python_reference.py), with the speed ratio
to the Rust model and to the FMU through fmpy.
"""

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

ROOT = Path(__file__).resolve().parent.parent
import python_reference  # benches/, the script's own folder
from aem_electrolyser import fmu_path
from aem_electrolyser.cli import quiet_on_closed_stdout

DAY = 86_400


def wind_like_setpoints(n, seed=42):
    """Mean-reverting random walk at 1 s, 45…105 % (same process as benches/model_step.rs)."""
    rng = np.random.default_rng(seed)
    steps = 3.0 * (rng.random(n) - 0.5)
    out = np.empty(n)
    x = 80.0
    for i in range(n):
        x = min(max(x + 0.02 * (80.0 - x) + steps[i], 45.0), 105.0)
        out[i] = x
    return out


def fmpy_day(fmu_path, setpoints):
    md = read_model_description(str(fmu_path))
    unzipdir = extract(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(
        guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench"
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    sp = [vr["setpoint"]]
    outs = [vr["current"], vr["voltage"], vr["power"], vr["h2Flow"]]
    values = [float(x) for x in setpoints]
    t = 0.0
    start = time.perf_counter()
    for u in values:
        fmu.setReal(sp, [u])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=1.0)
        fmu.getReal(outs)
        t += 1.0
    elapsed = time.perf_counter() - start
    fmu.terminate()
    fmu.freeInstance()
    return elapsed


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rust", type=Path, default=ROOT / "target" / "bench" / "rust.json")
    parser.add_argument("--fmu", type=Path, default=None, help="the FMU [default: the installed package's]")
    args = parser.parse_args()
    args.fmu = fmu_path(args.fmu)
    rust = json.loads(args.rust.read_text())
    setpoints = wind_like_setpoints(DAY)

    fmpy_s = fmpy_day(args.fmu, setpoints)
    start = time.perf_counter()
    python_reference.simulate(setpoints, dt=1.0)
    python_s = time.perf_counter() - start

    per_call_us = fmpy_s / DAY * 1e6
    share = rust["c_abi_ns"] * 1e-3 / per_call_us
    print(f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}")
    print(f"through fmpy, setReal+doStep+getReal(4):   {per_call_us:8.2f} us/step  (one day at 1 s: {fmpy_s:.2f} s)")
    print(f"FMU's own share of that call:               {100 * share:8.3f} %  ({rust['c_abi_ns']:.0f} ns in process)")
    print(f"Python/SciPy implementation, one day at 1 s: {python_s:8.3f} s")
    print(
        f"Rust model, one day at 1 s:                  {rust['day_s']:8.4f} s  -> {python_s / rust['day_s']:.0f}x faster than Python/SciPy"
    )
    print(f"FMU through fmpy vs Python/SciPy:            {python_s / fmpy_s:8.2f}x")


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
