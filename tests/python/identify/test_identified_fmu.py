"""packaging/package.py --parameters: an FMU whose parameter start values are identified ones.

The parameter file has the format `aem-identify fit -o` writes. The packaged FMU must carry
the values as start values in its model description (read back with fmpy), its binary must
use them as defaults (a simulation without start values gives the steady current K*u and
voltage V0 + R*I of the identified set), and the repository's modelDescription.xml must stay
untouched. Unknown names and wrong units are refused before anything is built.
"""

import json
import subprocess
import sys

import pytest
from fmpy import read_model_description, simulate_fmu

from conftest import REBUILDS_THE_LIBRARY, ROOT

# rebuilds the FMU's library from identified parameters
pytestmark = [pytest.mark.slow, REBUILDS_THE_LIBRARY]

PACKAGE = ROOT / "packaging" / "package.py"

#: Identified values (the synthetic campaign's truth) with the model description's units.
IDENTIFIED = {
    "gain": (0.51185, "A/%"),
    "tauZero": (79.838, "s"),
    "tauPole1": (2.6082, "s"),
    "tauPole2": (101.78, "s"),
    "rampUpLimit": (0.18003, "A/s"),
    "voltageIntercept": (36.404, "V"),
    "ohmicResistance": (0.14111, "Ohm"),
    "h2Coefficient": (9.4098, "Nl/(h.A)"),
}


def parameter_file(path, parameters, module="A", extra_modules=()):
    entries = [
        {
            "module": module,
            "parameters": {
                name: {
                    "value": value,
                    "unit": unit,
                    "standardError": 0.001,
                    "poorlyDetermined": False,
                    "source": "identified",
                }
                for name, (value, unit) in parameters.items()
            },
            "statistics": {"dynamics": {"rmseA": 0.151}},
        }
    ]
    entries += [{"module": m, "parameters": {}, "statistics": {}} for m in extra_modules]
    path.write_text(json.dumps({"generator": "aem-identify 0.1.0", "modules": entries}, indent=2))
    return path


def package(*args):
    # linux64 only: these tests are about the start values, which every platform shares.
    return subprocess.run(
        [sys.executable, str(PACKAGE), "--platforms", "linux64", *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )


def test_identified_values_are_the_start_values_and_the_binary_defaults(tmp_path):
    repo_xml = (ROOT / "modelDescription.xml").read_bytes()
    params = parameter_file(tmp_path / "params.json", IDENTIFIED)
    out = tmp_path / "Identified.fmu"
    result = package("--parameters", params, "--output", out)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (ROOT / "modelDescription.xml").read_bytes() == repo_xml, "the repository's model description changed"

    md = read_model_description(str(out))
    starts = {v.name: v for v in md.modelVariables if v.causality == "parameter"}
    for name, (value, unit) in IDENTIFIED.items():
        assert float(starts[name].start) == value, name
        assert starts[name].unit == unit, name
    # Parameters not in the file keep the model description's start values.
    assert float(starts["nominalCurrent"].start) == 53.35
    assert float(starts["minSetpoint"].start) == 60.0
    # A different model description has a different GUID.
    assert md.guid != read_model_description(str(ROOT / "modelDescription.xml")).guid

    # The binary's defaults are the identified values: no start values are set here.
    result = simulate_fmu(
        str(out),
        stop_time=10.0,
        step_size=1.0,
        output_interval=1.0,
        start_values={"setpoint": 100.0},
        output=["current", "voltage", "h2Flow"],
    )
    gain, v0, r, c = (IDENTIFIED[n][0] for n in ("gain", "voltageIntercept", "ohmicResistance", "h2Coefficient"))
    current = gain * 100.0
    assert result["current"][-1] == pytest.approx(current, rel=1e-12)
    assert result["voltage"][-1] == pytest.approx(v0 + r * current, rel=1e-12)
    assert result["h2Flow"][-1] == pytest.approx(c * current, rel=1e-12)


@pytest.mark.parametrize(
    "name, entry, message",
    [
        ("gainz", (0.5, "A/%"), "unknown parameter 'gainz'"),
        ("gain", (0.5, "A"), "has unit 'A', the FMU's is 'A/%'"),
        ("tauZero", (float("nan"), "s"), "is not a finite number"),
        ("tauPole1", (-1.0, "s"), "below its min"),
    ],
)
def test_bad_parameter_files_are_refused_before_building(tmp_path, name, entry, message):
    params = parameter_file(tmp_path / "bad.json", {name: entry})
    out = tmp_path / "bad.fmu"
    result = package("--parameters", params, "--output", out)
    assert result.returncode != 0
    assert message in result.stderr, result.stderr
    assert not out.exists()


def test_a_file_with_several_modules_needs_one_chosen(tmp_path):
    params = parameter_file(tmp_path / "two.json", {"gain": (0.5, "A/%")}, extra_modules=["B"])
    result = package("--parameters", params, "--output", tmp_path / "x.fmu")
    assert result.returncode != 0 and "choose one with --module" in result.stderr
    result = package("--parameters", params, "--module", "C", "--output", tmp_path / "x.fmu")
    assert result.returncode != 0 and "no module 'C'" in result.stderr
    (tmp_path / "broken.json").write_text("{ nope")
    result = package("--parameters", tmp_path / "broken.json", "--output", tmp_path / "x.fmu")
    assert result.returncode != 0 and "broken.json:1: not JSON" in result.stderr
