"""The release bundle as a user gets it (dist/, written by packaging/release.py): the linux wheel
installed into fresh virtual environments made here and used from a folder outside the
checkout, so nothing can be imported from it; the win_amd64 wheel's contents and tags and its
aem-identify.exe under Wine; the sdist built into a working wheel from its own files; the
checksums; one version everywhere.

Expectations: the closed-form steady state (I = K u, P = (V0 + R I) I), the closed-form KPIs of
an equal hub at constant power, the parameters the synthetic campaign was made with, and the
prequalification the checkout's own package computes on the same FMU.
"""

import csv
import hashlib
import json
import os
import re
import subprocess
import sys
import tarfile
import tomllib
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

from conftest import PAPER, ROOT, module_power, setpoint_for, windows_path

DIST = ROOT / "dist"
VERSION = tomllib.loads((ROOT / "Cargo.toml").read_text())["workspace"]["package"]["version"]
LINUX_TAG = "py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64"
#: The synthetic campaign's true parameters (aem-identify synthesize, CampaignSpec::test_truth).
TRUTH = dict(gain=0.512, rampUpLimit=0.18, voltageIntercept=36.4, ohmicResistance=0.1412)
#: kg per normal litre of hydrogen: M(H2) / V_m(0 °C, 1 atm).
KG_PER_NL = 2.01588e-3 / 22.413969545014137
UV = Path(sys.executable).parent / "uv"

# the release bundle in dist/ (packaging/release.py) in fresh environments
pytestmark = [pytest.mark.slow]


def dist_file(name):
    path = DIST / name
    if not path.is_file():
        pytest.fail(f"{path} not found: scripts/test.sh writes dist/ with packaging/release.py")
    return path


def run(cmd, cwd, env=None, timeout=600, check=True):
    done = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)
    if check:
        assert done.returncode == 0, f"{cmd}\nexit {done.returncode}\n{done.stdout}\n{done.stderr}"
    return done


def fresh_venv(folder, requirement):
    """A new virtual environment in `folder` with `requirement` installed (uv, from the registry
    and its cache); its environment for subprocesses: no AEM_FMU, no PYTHONPATH."""
    run([UV, "venv", "--quiet", "--python", sys.executable, folder], cwd=folder.parent)
    run([UV, "pip", "install", "--quiet", "--python", folder / "bin" / "python", requirement], cwd=folder.parent)
    env = {k: v for k, v in os.environ.items() if k not in ("AEM_FMU", "PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{folder / 'bin'}{os.pathsep}{env['PATH']}"
    return folder / "bin", env


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(bin folder, environment, working folder) of a fresh venv with the linux wheel and the
    extras [study,reserves]; the working folder is outside the checkout."""
    wheel = dist_file(f"aem_electrolyser-{VERSION}-{LINUX_TAG}.whl")
    base = tmp_path_factory.mktemp("installed")
    bin_dir, env = fresh_venv(base / "venv", f"{wheel}[study,reserves]")
    work = base / "work"
    work.mkdir()
    assert not work.resolve().is_relative_to(ROOT)
    return bin_dir, env, work


def test_the_bundled_fmu_in_fmpy_gives_the_closed_form_steady_state(installed):
    bin_dir, env, work = installed
    code = """
import json, aem_electrolyser, fmpy
path = aem_electrolyser.fmu_path()
result = fmpy.simulate_fmu(str(path), stop_time=10.0, output_interval=1.0, start_values={"setpoint": 80.0},
                           output=["current", "voltage", "power"])
print(json.dumps({"path": str(path), "module": aem_electrolyser.__file__, "version": aem_electrolyser.__version__,
                  "current": result["current"].tolist(), "power": result["power"].tolist()}))
"""
    out = json.loads(run([bin_dir / "python", "-c", code], cwd=work, env=env).stdout)
    site = (bin_dir.parent / "lib").resolve()
    assert Path(out["module"]).resolve().is_relative_to(site), out["module"]  # the installed copy, not the checkout
    assert Path(out["path"]).resolve().is_relative_to(site) and out["path"].endswith("data/AemElectrolyser.fmu")
    assert out["version"] == VERSION
    current = PAPER["gain"] * 80.0
    power = (PAPER["voltageIntercept"] + PAPER["ohmicResistance"] * current) * current
    assert out["current"] == pytest.approx([current] * len(out["current"]), rel=1e-12)
    assert out["power"] == pytest.approx([power] * len(out["power"]), rel=1e-12)


def summary(folder):
    with open(folder / "summary.csv", newline="") as f:
        return sorted(tuple(sorted(row.items())) for row in csv.DictReader(f))


def test_aem_prequalify_of_the_wheel_gives_the_checkouts_capacities(installed, tmp_path, fmu_path):
    bin_dir, env, work = installed
    args = ["--modules", 100, "--baseline", 80, "--products", "mFRR up,FFR 49.7 Hz", "--jobs", 2, "--no-plots"]
    run([bin_dir / "aem-prequalify", *args, "--out", tmp_path / "wheel"], cwd=work, env=env)
    run(
        [
            sys.executable,
            "-m",
            "aem_electrolyser.reserves.prequalify",
            "--fmu",
            fmu_path,
            *args,
            "--out",
            tmp_path / "checkout",
        ],
        cwd=ROOT,
    )
    assert summary(tmp_path / "wheel") == summary(tmp_path / "checkout")
    assert len(summary(tmp_path / "wheel")) == 4  # two products, plain and compensated


def test_aem_study_of_the_wheel_runs_two_scenarios_on_two_workers(installed, tmp_path):
    """A LocalCluster of 2 worker processes of the venv (which import the installed package):
    an equal hub at constant power, 400 and 500 modules, gives E = P t and H2 = n c K u t."""
    bin_dir, env, work = installed
    hub_power, hours = 0.8e6, 1.0
    (work / "flat.csv").write_text(f"time [s],power [kW]\n0,{hub_power / 1e3}\n{hours * 3600},{hub_power / 1e3}\n")
    (work / "study.toml").write_text(
        f'[study]\ntitle = "wheel"\nhorizon = "{hours} h"\n'
        '[series.flat]\nfile = "flat.csv"\ncolumn = "power [kW]"\n'
        "[axes]\nnModules = [400, 500]\n"
    )
    run([bin_dir / "aem-study", "study.toml", "--workers", 2, "--no-plots", "--out", "out"], cwd=work, env=env)
    with open(work / "out" / "kpis.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert sorted(float(r["modules [1]"]) for r in rows) == [400, 500]
    for row in rows:
        n = float(row["modules [1]"])
        assert row["status"] == "done", row
        current = PAPER["gain"] * setpoint_for(hub_power / n)
        assert float(row["energy drawn [MWh]"]) == pytest.approx(hub_power * hours / 1e6, rel=1e-9)
        assert float(row["hydrogen [kg]"]) == pytest.approx(
            n * PAPER["h2Coefficient"] * current * hours * KG_PER_NL, rel=1e-9
        )
        assert float(row["hub rated power [MW]"]) == pytest.approx(
            n * module_power(PAPER["maxSetpoint"]) / 1e6, rel=1e-9
        )


def identified(params_file):
    data = json.loads(Path(params_file).read_text())
    (module,) = data["modules"]
    return {k: v["value"] for k, v in module["parameters"].items()}


def test_aem_identify_of_the_wheel_recovers_the_synthetic_truth(installed):
    bin_dir, env, work = installed
    run(
        [bin_dir / "aem-identify", "synthesize", "campaign", "--days", 2, "--hours", 4, "--seed", 11], cwd=work, env=env
    )
    run([bin_dir / "aem-identify", "fit", "campaign", "-o", "params.json"], cwd=work, env=env)
    found = identified(work / "params.json")
    for name, true in TRUTH.items():
        assert found[name] == pytest.approx(true, rel=0.01), name


def test_a_missing_extra_names_the_pip_install_that_brings_it(installed):
    bin_dir, env, work = installed
    done = run([bin_dir / "python", "-m", "aem_electrolyser.examples.grid_cosim"], cwd=work, env=env, check=False)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        "python -m aem_electrolyser.examples.grid_cosim needs the [grid] extra (tops is not installed): "
        "pip install 'aem-electrolyser[grid]'"
    ], done.stderr


def test_a_core_install_names_the_extra_of_each_command(tmp_path):
    """The core wheel alone (fmpy, numpy, scipy): every command that needs more says which extra."""
    bin_dir, env = fresh_venv(tmp_path / "venv", str(dist_file(f"aem_electrolyser-{VERSION}-{LINUX_TAG}.whl")))
    for command, extra in (
        (["aem-study", "x.toml"], "study"),
        (["aem-prequalify"], "reserves"),
        (["python", "-m", "aem_electrolyser.examples.step_schedule"], "plots"),
        (["python", "-m", "aem_electrolyser.mosaik.cigre_scenario"], "mosaik"),
        (["python", "-m", "aem_electrolyser.helics.hub_federate"], "helics"),
    ):
        done = run([bin_dir / command[0], *command[1:]], cwd=tmp_path, env=env, check=False)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 1 and len(lines) == 1, (command, done.stderr)
        assert lines[0].endswith(f"pip install 'aem-electrolyser[{extra}]'"), lines[0]
    version = run([bin_dir / "aem-identify", "--version"], cwd=tmp_path, env=env).stdout
    assert VERSION in version


def wheel_metadata(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        info = f"aem_electrolyser-{VERSION}.dist-info/"
        return names, z.read(info + "WHEEL").decode(), z.read(info + "METADATA").decode(), z


@pytest.mark.wine
def test_the_windows_wheel_holds_the_windows_commands_and_both_binaries(wine, tmp_path):
    wheel = dist_file(f"aem_electrolyser-{VERSION}-py3-none-win_amd64.whl")
    names, tags, metadata, _ = wheel_metadata(wheel)
    assert "Tag: py3-none-win_amd64" in tags.splitlines() and "Root-Is-Purelib: false" in tags
    assert f"Version: {VERSION}" in metadata.splitlines()
    for name in (
        "aem_electrolyser/bin/aem-identify.exe",
        "aem_electrolyser/bin/aem-run.exe",
        "aem_electrolyser/bin/aem_drive.dll",
        "aem_electrolyser/data/AemElectrolyser.fmu",
        "aem_electrolyser/__init__.py",
        "aem_electrolyser/locate.py",
    ):
        assert name in names, name
    assert not any(n.startswith("aem_electrolyser/bin/") and not n.endswith((".exe", ".dll")) for n in names)
    with zipfile.ZipFile(wheel) as z:
        z.extract("aem_electrolyser/bin/aem-identify.exe", tmp_path)
        fmu = tmp_path / "AemElectrolyser.fmu"
        fmu.write_bytes(z.read("aem_electrolyser/data/AemElectrolyser.fmu"))
    with zipfile.ZipFile(fmu) as z:
        assert {"binaries/win64/AemElectrolyser.dll", "binaries/linux64/AemElectrolyser.so"} <= set(z.namelist())
    exe = tmp_path / "aem_electrolyser" / "bin" / "aem-identify.exe"
    assert VERSION in wine(exe, "--version")
    wine(exe, "synthesize", windows_path(tmp_path / "campaign"), "--days", "1", "--hours", "2")
    assert list((tmp_path / "campaign").glob("*.csv"))


def test_the_linux_wheel_is_tagged_manylinux2014_and_holds_the_linux_commands():
    names, tags, metadata, _ = wheel_metadata(dist_file(f"aem_electrolyser-{VERSION}-{LINUX_TAG}.whl"))
    assert {"Tag: py3-none-manylinux_2_17_x86_64", "Tag: py3-none-manylinux2014_x86_64"} <= set(tags.splitlines())
    assert {
        "aem_electrolyser/bin/aem-identify",
        "aem_electrolyser/bin/aem-run",
        "aem_electrolyser/bin/libaem_drive.so",
    } <= set(names)
    for extra in ("study", "reserves", "mosaik", "helics", "grid", "plots", "all"):
        assert f"Provides-Extra: {extra}" in metadata.splitlines(), extra


@pytest.mark.serial
def test_the_sdist_builds_a_working_wheel_from_its_own_files(tmp_path):
    """Unpacked outside the checkout and built there (cargo, cargo-zigbuild and this venv's
    hatchling). The checkout's cargo target folder is the build's CARGO_TARGET_DIR, as a cache:
    the registry's crates compiled by the release are reused, the workspace's own crates
    (another path) are compiled from the sdist's files, and the build's outputs go to
    target/wheel-artefacts/, not over the checkout's."""
    sdist = dist_file(f"aem_electrolyser-{VERSION}.tar.gz")
    with tarfile.open(sdist) as tar:
        tar.extractall(tmp_path, filter="data")
    source = tmp_path / f"aem_electrolyser-{VERSION}"
    assert not (source / ".git").exists() and not (source / "target").exists()
    env = dict(os.environ, CARGO_TARGET_DIR=str(ROOT / "target"))
    env.pop("AEM_WHEEL_PLATFORM", None)
    run(
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", tmp_path / "wheel", source],
        cwd=tmp_path,
        env=env,
        timeout=1200,
    )
    (wheel,) = (tmp_path / "wheel").glob("*.whl")
    # cargo-zigbuild is in this venv: the build links against glibc 2.17, as the release's does.
    assert wheel.name == f"aem_electrolyser-{VERSION}-{LINUX_TAG}.whl"
    bin_dir, venv_env = fresh_venv(tmp_path / "venv", str(wheel))
    code = """
import ctypes
import aem_electrolyser, fmpy
from aem_electrolyser.locate import drive_library

r = fmpy.simulate_fmu(str(aem_electrolyser.fmu_path()), stop_time=2.0, start_values={"setpoint": 70.0}, output=["current"])
print(r["current"][-1])
print(drive_library().relative_to(aem_electrolyser.locate.PACKAGE), ctypes.CDLL(str(drive_library())).aem_drive_series)
"""
    current, drive = run([bin_dir / "python", "-c", code], cwd=tmp_path, env=venv_env).stdout.splitlines()
    assert float(current) == pytest.approx(PAPER["gain"] * 70.0, rel=1e-12)
    assert drive.startswith("bin/libaem_drive.so <_FuncPtr"), drive  # the wheel's own stepping loop
    assert VERSION in run([bin_dir / "aem-identify", "--version"], cwd=tmp_path, env=venv_env).stdout


def test_sha256sums_verifies_every_file_of_the_bundle():
    sums = dist_file("SHA256SUMS")
    listed = {}
    for line in sums.read_text().splitlines():
        digest, name = re.fullmatch(r"([0-9a-f]{64})  (\S+)", line).groups()
        listed[name] = digest
    files = {p.name for p in DIST.iterdir() if p.is_file() and p.name != "SHA256SUMS"}
    assert set(listed) == files
    assert files == {
        f"AemElectrolyser-{VERSION}.fmu",
        f"aem_electrolyser-{VERSION}-{LINUX_TAG}.whl",
        f"aem_electrolyser-{VERSION}-py3-none-win_amd64.whl",
        f"aem_electrolyser-{VERSION}.tar.gz",
        f"aem-identify-{VERSION}-linux-x86_64",
        f"aem-identify-{VERSION}-windows-x86_64.exe",
    }
    for name, digest in listed.items():
        assert hashlib.sha256((DIST / name).read_bytes()).hexdigest() == digest, name
    done = run(["sha256sum", "-c", "SHA256SUMS"], cwd=DIST)
    assert done.stdout.count(": OK") == len(files)


def test_one_version_everywhere():
    """Cargo workspace, model description, wheels, sdist, and the FMU's own model description and
    documentation."""
    assert ET.parse(ROOT / "modelDescription.xml").getroot().get("version") == VERSION
    with zipfile.ZipFile(dist_file(f"AemElectrolyser-{VERSION}.fmu")) as fmu:
        assert ET.fromstring(fmu.read("modelDescription.xml")).get("version") == VERSION
        assert f'<span id="version">{VERSION}</span>' in fmu.read("documentation/index.html").decode()
    for wheel in (f"aem_electrolyser-{VERSION}-{LINUX_TAG}.whl", f"aem_electrolyser-{VERSION}-py3-none-win_amd64.whl"):
        _, _, metadata, _ = wheel_metadata(dist_file(wheel))
        assert f"Version: {VERSION}" in metadata.splitlines()
    with tarfile.open(dist_file(f"aem_electrolyser-{VERSION}.tar.gz")) as tar:
        pkg_info = tar.extractfile(f"aem_electrolyser-{VERSION}/PKG-INFO").read().decode()
    assert f"Version: {VERSION}" in pkg_info.splitlines()
