"""Benchmark: one day at 1 s of a 25 000-module `equal` hub following a wind-like power
reference through fmpy (FMU2Slave: setReal, doStep, getReal every second), as issue 4 asks.
Prints wall seconds per simulated day. Run by scripts/bench.sh after packaging the FMU."""

import time
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from python_reference import PAPER  # benches/, the script's own folder (Table I from tests/data)
from wind_reference import wind_reference  # benches/, the script's own folder
from aem_electrolyser import fmu_path
from aem_electrolyser.cli import quiet_on_closed_stdout

ROOT = Path(__file__).resolve().parents[1]
FMU = fmu_path()
DAY, MODULES = 86_400, 25_000


def main():
    md = read_model_description(str(FMU))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(str(FMU))
    i_rated = PAPER["gain"] * PAPER["maxSetpoint"]
    reference = wind_reference(
        DAY, MODULES * (PAPER["voltageIntercept"] + PAPER["ohmicResistance"] * i_rated) * i_rated
    )
    fmu = FMU2Slave(
        guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench"
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.setInteger([vr["nModules"], vr["belowMinimum"]], [MODULES, 1])
    fmu.setBoolean([vr["powerInput"]], [True])
    fmu.setReal([vr["powerReference"]], [float(reference[0])])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    ref_vr, out_vr = [vr["powerReference"]], [vr["hubPower"]]
    start = time.perf_counter()
    t, energy = 0.0, 0.0
    for p in reference:
        fmu.setReal(ref_vr, [float(p)])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=1.0)
        energy += fmu.getReal(out_vr)[0]
        t += 1.0
    seconds = time.perf_counter() - start
    fmu.terminate()
    fmu.freeInstance()
    print(
        f"fmpy equal hub, {MODULES} modules, one day at 1 s: {seconds:.2f} s/day "
        f"({seconds / DAY * 1e6:.1f} us per step incl. setReal/doStep/getReal), energy {energy / 3.6e9:.1f} MWh"
    )


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
