#!/usr/bin/env python3
"""Write the fuzzers' seed corpora from valid inputs (made here, not stored in the repository):

    fuzz/corpus/fmu_state/        serialised FMU states of the packaged FMU (fmpy): a module
                                  after steps, a hub with a parameter file, in standby; each as
                                  raw bytes (first byte 0) and as payload to envelope (first byte 1)
    fuzz/corpus/parameter_file/   parameter files as aem-identify writes them
    fuzz/corpus/identify_csv/     the first rows of synthetic logs (aem-identify synthesize
                                  --broken), with seconds, RFC 3339 times and a module column
                                  (first byte 1: the reader is told that column `unit` holds it),
                                  and a `;`-separated export with decimal commas (detected and given)

Needs target/fmu/AemElectrolyser.fmu and target/release/aem-identify (scripts/test.sh builds both).
"""

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from aem_electrolyser import locate

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "fuzz" / "corpus"
FMU = locate.fmu_path()
IDENTIFY = locate.binary("aem-identify")
#: The paper's Table I and operating window, name -> (value, unit), from the tests' one copy.
TABLE_I = {
    row["name"]: (row["value"], row["unit"])
    for row in json.loads((ROOT / "tests" / "data" / "table_i.json").read_text(encoding="utf-8"))
}


def parameter_file(scales):
    modules = [
        {
            "module": f"M{k}",
            "parameters": {
                name: {
                    "value": v * s if name != "maxSetpoint" else v,
                    "unit": u,
                    "standardError": 0.001,
                    "poorlyDetermined": False,
                    "source": "identified",
                }
                for name, (v, u) in TABLE_I.items()
            },
            "statistics": {"rowsRead": 1000},
        }
        for k, s in enumerate(scales)
    ]
    return {"generator": "seeds", "modules": modules}


def states(tmp):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(FMU))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipdir = extract(str(FMU), str(tmp / "fmu"))
    params = tmp / "modules.json"
    params.write_text(json.dumps(parameter_file([1.0, 1.02])))
    out = []
    for hub in (False, True):
        fmu = FMU2Slave(
            guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="seed"
        )
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        if hub:
            fmu.setInteger([vr["nModules"], vr["dispatch"], vr["belowMinimum"]], [5, 2, 1])
            fmu.setString([vr["moduleParameterFile"]], [str(params)])
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        t = 0.0
        for setpoint, h in ((100.0, 1.0), (70.0, 30.0), (30.0, 100.0)):
            fmu.setReal([vr["setpoint"]], [setpoint])
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            t += h
            state = fmu.getFMUstate()
            out.append(bytes(fmu.serializeFMUstate(state)))
            fmu.freeFMUstate(state)
        fmu.terminate()
        fmu.freeInstance()
    return out


def main():
    for tool in (FMU, IDENTIFY):
        if not tool.is_file():
            sys.exit(f"seeds.py: {tool} not found (bash scripts/test.sh builds it)")
    shutil.rmtree(CORPUS, ignore_errors=True)
    for target in ("fmu_state", "parameter_file", "identify_csv"):
        (CORPUS / target).mkdir(parents=True)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k, state in enumerate(states(tmp)):
            (CORPUS / "fmu_state" / f"raw{k}").write_bytes(b"\x00" + state)
            (CORPUS / "fmu_state" / f"payload{k}").write_bytes(b"\x01" + state[16:-4])
        for k, scales in enumerate(([1.0], [0.98, 1.0, 1.03], [1.0, 0.5])):
            (CORPUS / "parameter_file" / f"file{k}.json").write_text(json.dumps(parameter_file(scales), indent=1))
        for name, extra in (("seconds", []), ("rfc3339", ["--rfc3339"])):
            subprocess.run(
                [IDENTIFY, "synthesize", tmp / name, "--days", "1", "--broken", *extra], check=True, capture_output=True
            )
            lines = (tmp / name / "day01.csv").read_text().splitlines()
            (CORPUS / "identify_csv" / f"{name}.csv").write_bytes(b"\x00" + ("\n".join(lines[:40]) + "\n").encode())
        lines = (tmp / "seconds" / "day01.csv").read_text().splitlines()
        with_module = [lines[0] + ",unit"] + [f"{line},{'AB'[k % 2]}" for k, line in enumerate(lines[1:30])]
        (CORPUS / "identify_csv" / "modules.csv").write_bytes(b"\x01" + ("\n".join(with_module) + "\n").encode())
        # European exports: `;` and a decimal comma, BOM and CRLF; detected (0x00) and given (0x0a).
        european = "\ufeff" + "\r\n".join(";".join(f.replace(".", ",") for f in line.split(",")) for line in lines[:40])
        for choice, name in ((0x00, "semicolon_detected"), (0x0A, "semicolon_given")):
            (CORPUS / "identify_csv" / f"{name}.csv").write_bytes(bytes([choice]) + (european + "\r\n").encode())
    for target in sorted(CORPUS.iterdir()):
        print(f"{target.relative_to(ROOT)}: {len(list(target.iterdir()))} seeds")


if __name__ == "__main__":
    main()
