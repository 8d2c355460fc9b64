"""The README's first command from nothing: scripts/demo.sh's Python environment made exactly as
the demo makes it (scripts/demo-venv.sh, the script the demo runs) into a fresh, empty venv of
the machine's python3 with the pip that interpreter bundles (23.x on Python 3.11: the oldest
pip a supported Python brings), then the demo itself run in that venv on the checkout's FMU.

Expectations: pip accepts requirements.txt as constraints (it refuses a constraints file that
holds extras: "Constraints cannot have extras"), the versions it installs are requirements.txt's
pins, and the demo's table starts at the paper's steady state I = K·u for u = 100 %.
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import PAPER, ROOT

#: The packages the demo's environment holds at requirements.txt's versions.
DEMO_PACKAGES = ("fmpy", "numpy", "scipy", "matplotlib")

pytestmark = [pytest.mark.slow]


def pins() -> dict:
    """requirements.txt's name -> version (lines `name==version`)."""
    out = {}
    for line in (ROOT / "requirements.txt").read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, _, version = line.partition("==")
            out[name.strip()] = version.strip()
    return out


def normal(name: str) -> str:
    """A distribution's name as PEP 503 compares it (pip lists fmpy as FMPy)."""
    return re.sub(r"[-_.]+", "-", name).lower()


def test_requirements_hold_no_extras():
    """pip takes requirements.txt as the demo's constraints; a constraint with extras is refused."""
    with_extras = [name for name in pins() if "[" in name]
    assert not with_extras, f"requirements.txt: pip refuses extras in a constraints file: {with_extras}"


def system_python() -> str:
    """The machine's python3, not this test's venv (the demo starts from nothing)."""
    path = os.pathsep.join(p for p in os.environ["PATH"].split(os.pathsep) if not p.startswith(str(ROOT / ".venv")))
    found = shutil.which("python3", path=path)
    assert found, "no python3 on PATH besides the checkout's .venv"
    return found


def test_demo_environment_from_an_empty_venv(tmp_path):
    """scripts/demo-venv.sh into a new venv with the interpreter's bundled pip, then the demo."""
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH", "AEM_FMU", "PIP_CONSTRAINT")}
    python3 = system_python()
    env["PATH"] = os.pathsep.join([str(Path(python3).parent), "/usr/bin", "/bin"])
    bundled = subprocess.run(
        [python3, "-c", "import ensurepip; print(ensurepip.version())"], capture_output=True, text=True, check=True
    ).stdout.strip()
    venv = tmp_path / "venv"
    done = subprocess.run(
        ["bash", str(ROOT / "scripts" / "demo-venv.sh"), str(venv)],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,
    )
    assert done.returncode == 0, f"the demo's install failed:\n{done.stdout}\n{done.stderr}"
    python = venv / "bin" / "python"
    pip = subprocess.run([python, "-m", "pip", "--version"], capture_output=True, text=True, check=True).stdout
    assert pip.split()[1] == bundled, f"not the interpreter's bundled pip {bundled}: {pip}"
    listed = subprocess.run(
        [python, "-m", "pip", "list", "--format=freeze", "--disable-pip-version-check"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    installed = {normal(n): v for n, v in (line.split("==", 1) for line in listed.splitlines() if "==" in line)}
    wanted = {normal(n): v for n, v in pins().items()}
    for name in map(normal, DEMO_PACKAGES):
        assert installed.get(name) == wanted[name], f"{name}: {installed.get(name)} installed, {wanted[name]} pinned"

    # The demo's last command, in that environment, on the FMU the release step packaged.
    fmu = ROOT / "target" / "fmu" / "AemElectrolyser.fmu"
    if not fmu.is_file():
        pytest.fail(f"{fmu} not found: scripts/test.sh packages it with packaging/release.py")
    out = tmp_path / "out"
    out.mkdir()
    demo = subprocess.run(
        [python, "-m", "aem_electrolyser.examples.step_schedule", "--out", str(out)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**env, "MPLBACKEND": "Agg"},
        timeout=300,
    )
    assert demo.returncode == 0, f"the demo failed:\n{demo.stdout}\n{demo.stderr}"
    rows = [line.split() for line in demo.stdout.splitlines() if re.match(r"^\s*0(\.0+)?\s", line)]
    assert rows, f"no row at t = 0 s in the demo's table:\n{demo.stdout}"
    current = float(rows[0][2])
    assert current == pytest.approx(PAPER["gain"] * 100.0, rel=1e-6), demo.stdout
