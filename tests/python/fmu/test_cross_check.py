"""The FMI cross-check tree (packaging/cross_check.py): fmpy's vendor-repository validation
finds no problem, fmpy's own cross-check import of the linux64 FMU passes against the
closed-form reference, and the FMU matches that reference far tighter than the cross-check's
band (the reference is the paper's model in closed form, not the FMU's output)."""

import subprocess
import sys
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.util import read_csv

from conftest import ROOT

SCRIPT = ROOT / "packaging" / "cross_check.py"
MODEL = "AemElectrolyser"


def run(cmd, cwd=None):
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, cwd=cwd)
    assert done.returncode == 0, f"{cmd}\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.fixture(scope="module")
def tree(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("cross-check")
    run([sys.executable, SCRIPT, "--fmu", fmu_path, "--out", out])
    return out


def model_folders(tree):
    return sorted((tree / "fmus" / "2.0" / "cs").glob(f"*/aem-electrolyser-fmu/*/{MODEL}"))


def test_the_tree_has_a_folder_for_every_platform_inside_the_fmu(tree, fmu_path):
    with zipfile.ZipFile(fmu_path) as z:
        platforms = sorted({n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") == 2})
    folders = model_folders(tree)
    assert [f.parts[-4] for f in folders] == platforms
    for folder in folders:
        names = sorted(p.name for p in folder.iterdir())
        assert names == sorted(
            [f"{MODEL}.fmu", f"{MODEL}_in.csv", f"{MODEL}_ref.csv", f"{MODEL}_ref.opt", "ReadMe.txt"]
        )


#: `python -m fmpy.cross_check` as shipped, but for the result plot (plotly with kaleido, which
#: fetches a browser when it exports an image): every check and result file stays fmpy's own.
FMPY_CROSS_CHECK = """
import runpy, sys
import fmpy.cross_check.cross_check as cc
cc.plot_result = lambda *args, **kwargs: None
sys.argv = ["fmpy.cross_check", *sys.argv[1:]]
runpy.run_module("fmpy.cross_check", run_name="__main__")
"""


def test_fmpy_imports_the_linux_fmu_and_the_vendor_tree_validates(tree):
    run(
        [
            sys.executable,
            "-c",
            FMPY_CROSS_CHECK,
            "--fmus_dir",
            tree / "fmus",
            "--include",
            "linux64",
            "--simulate",
            "--result_dir",
            tree / "results",
            "--report",
            tree / "report.html",
        ],
        cwd=tree,
    )
    passed = list((tree / "results").rglob("passed"))
    failed = list((tree / "results").rglob("failed")) + list((tree / "results").rglob("rejected"))
    assert len(passed) == 1 and not failed, (passed, failed)
    out = run([sys.executable, "-m", "fmpy.cross_check.validate_vendor_repo", tree])
    assert "0 problems found" in out, out
    assert f"Validated {len(model_folders(tree))} FMUs and 1 results" in out, out


def test_the_fmu_meets_the_closed_form_reference_to_1e9(tree):
    (folder,) = [f for f in model_folders(tree) if f.parts[-4] == "linux64"]
    reference = read_csv(folder / f"{MODEL}_ref.csv")
    inputs = read_csv(folder / f"{MODEL}_in.csv")
    result = simulate_fmu(
        folder / f"{MODEL}.fmu",
        stop_time=760.0,
        step_size=1.0,
        output_interval=1.0,
        input=inputs,
        output=list(reference.dtype.names[1:]),
    )
    assert len(result) == len(reference)
    np.testing.assert_array_equal(result["time"], reference["time"])
    for name in reference.dtype.names[1:]:
        np.testing.assert_allclose(result[name], reference[name], rtol=1e-9, atol=1e-9, err_msg=name)
