"""The user pages as a user who installed the Linux wheel reads them, without a checkout: the
pages' Python snippets (taken from the pages themselves, so the test follows the docs) run in a
fresh virtual environment with the wheel, from a folder outside the checkout; `aem-study
--example hub_sizing` writes the example study that studies.md runs and `aem-study
hub_sizing.toml --list` reads it; every command the pages write as installed exists there. And,
without the wheel: the user pages write commands as installed (no `.venv/bin/` in a command, the
checkout's form said once per page at most) and open the FMU through `aem_electrolyser.fmu_path()`
(no `target/fmu`).

User pages: docs/*.md but development.md (for contributors), and README.md but its Quick start
and Documentation sections (a checkout's); in getting-started.md the section on the build from
source is a checkout's too.

Expectations: the closed-form steady state I = K u of a module whose gain comes from the
parameter file (identification.md's snippet), the single module taking the file's first module.
"""

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from conftest import PAPER, ROOT

DIST = ROOT / "dist"
VERSION = tomllib.loads((ROOT / "Cargo.toml").read_text())["workspace"]["package"]["version"]
LINUX_WHEEL = f"aem_electrolyser-{VERSION}-py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64.whl"
UV = Path(sys.executable).parent / "uv"

#: Sections (by heading) that describe a checkout, not the installed package.
CHECKOUT_SECTIONS = {
    "README.md": {"Quick start", "Documentation"},
    "getting-started.md": {"Build from source: the quick start"},
}
#: Python blocks of the user pages that are not run here, with the reason.
NOT_RUN = {
    "cosimulation.md": "a fragment of the mosaik scenario (the [mosaik] extra), not a program",
    "studies.md": "dask-jobqueue on a SLURM cluster",
}


def user_pages():
    pages = [p for p in sorted((ROOT / "docs").glob("*.md")) if p.name != "development.md"]
    return [ROOT / "README.md", *pages]


def sections(page):
    """[(heading, text)] of a page, split at its level-2 headings (fenced blocks kept whole)."""
    out, heading, lines, fenced = [], "", [], False
    for line in page.read_text("utf-8").splitlines(keepends=True):
        if line.startswith("```"):
            fenced = not fenced
        if not fenced and line.startswith("## "):
            out.append((heading, "".join(lines)))
            heading, lines = line[3:].strip(), []
        lines.append(line)
    out.append((heading, "".join(lines)))
    return out


def user_text(page):
    """The page without its checkout sections."""
    skip = CHECKOUT_SECTIONS.get(page.name, set())
    return "".join(text for heading, text in sections(page) if heading not in skip)


FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def python_blocks(page):
    """[(where, code)] of the page's user sections' ```python blocks; the code is preceded by blank
    lines so that a traceback's line numbers are the page's."""
    text = page.read_text("utf-8")
    user = user_text(page)
    out = []
    for m in FENCE.finditer(text):
        if m.group(1) == "python" and m.group(0) in user:
            line = text[: m.start(2)].count("\n")
            out.append((f"{page.relative_to(ROOT)}:{line + 1}", "\n" * line + m.group(2)))
    return out


# --- the pages' text, without the wheel -----------------------------------------------------------


def test_user_pages_write_commands_as_installed():
    """No `.venv/bin/` in a command block of a user page, and outside them once per page at most,
    saying it is a checkout's; no `target/fmu` (the FMU is `aem_electrolyser.fmu_path()`); the
    example study as `aem-study --example`, not the checkout's examples/ folder."""
    problems = []
    for page in user_pages():
        text = user_text(page)
        blocks = "".join(m.group(0) for m in FENCE.finditer(text))
        prose = FENCE.sub("", text)
        name = page.relative_to(ROOT)
        if ".venv/bin" in blocks:
            problems.append(f"{name}: .venv/bin in a command block")
        notes = [m.start() for m in re.finditer(r"\.venv/bin", prose)]
        if len(notes) > 1:
            problems.append(f"{name}: .venv/bin said {len(notes)} times (once per page at most)")
        problems += [
            f"{name}: .venv/bin without 'checkout' before it"
            for at in notes
            if "checkout" not in prose[max(0, at - 200) : at]
        ]
        if "target/fmu" in text:
            problems.append(f"{name}: target/fmu (use aem_electrolyser.fmu_path())")
        if re.search(r"aem-study\s+examples/", text):
            problems.append(f"{name}: aem-study examples/... (the wheel has no examples/: aem-study --example NAME)")
    assert not problems, "\n".join(problems)


def test_the_pages_whose_python_is_not_run_have_python():
    """NOT_RUN stays true to the pages (every other python block runs from the wheel, below)."""
    for page in user_pages():
        if page.name in NOT_RUN:
            assert python_blocks(page), f"{page.name} is in NOT_RUN but has no python block"


# --- the wheel, installed ---------------------------------------------------------------------------


def run(cmd, cwd, env, timeout=600, check=True):
    done = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)
    if check:
        assert done.returncode == 0, f"{cmd}\nexit {done.returncode}\n{done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(bin folder, environment, working folder) of a fresh venv with the Linux wheel and its
    [study] extra, installed by uv from its cache where it can (as platforms/test_distribution.py
    does); the working folder is outside the checkout."""
    wheel = DIST / LINUX_WHEEL
    if not wheel.is_file():
        pytest.fail(f"{wheel} not found: scripts/test.sh writes dist/ with packaging/release.py")
    base = tmp_path_factory.mktemp("wheel-docs")
    venv = base / "venv"
    run([UV, "venv", "--quiet", "--python", sys.executable, venv], cwd=base, env=None)
    install = [UV, "pip", "install", "--quiet", "--python", venv / "bin" / "python", f"{wheel}[study]"]
    if run([*install, "--offline"], cwd=base, env=None, check=False).returncode != 0:  # not all in uv's cache
        run(install, cwd=base, env=None)
    env = {k: v for k, v in os.environ.items() if k not in ("AEM_FMU", "PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env['PATH']}"
    work = base / "work"
    work.mkdir()
    assert not work.resolve().is_relative_to(ROOT)
    return venv / "bin", env, work


#: Runs the snippets given as JSON [[where, code], ...], each in a namespace of its own, and prints
#: {where: {output: [first, last]}} of the `result` each leaves.
DRIVER = """
import json, sys
import numpy as np
out = {}
for where, code in json.loads(sys.stdin.read()):
    namespace = {"__name__": "__main__"}
    exec(compile(code, where, "exec"), namespace)
    result = namespace.get("result")
    out[where] = None if result is None else {
        name: [float(result[name][0]), float(result[name][-1]), bool(np.isfinite(result[name]).all())]
        for name in result.dtype.names
    }
print(json.dumps(out))
"""


@pytest.mark.slow
def test_the_user_pages_python_snippets_run_from_the_wheel(installed):
    """Every ```python block of the user pages (README's Use the FMU, Using the FMU, Hub and
    dispatch, Identification; NOT_RUN says why the others are not), as written, in one
    interpreter of the venv, in a folder outside the checkout with the params.json that
    identification.md's snippet names (two modules: a single module takes the first)."""
    bin_dir, env, work = installed
    snippets, seen = [], set()
    for page in user_pages():
        if page.name in NOT_RUN:
            continue
        for where, code in python_blocks(page):
            if code.strip() not in seen:  # README's and Using the FMU's are the same
                seen.add(code.strip())
                snippets.append((where, code))
    names = {where.split(":")[0] for where, _ in snippets}
    assert {"README.md", "docs/hub.md", "docs/identification.md"} <= names, names
    gains = [0.6, 0.7]
    (work / "params.json").write_text(
        json.dumps(
            {
                "generator": "test_wheel_docs",
                "modules": [
                    {"module": f"M{i}", "parameters": {"gain": {"value": g, "unit": "A/%", "source": "identified"}}}
                    for i, g in enumerate(gains)
                ],
            }
        )
    )
    done = subprocess.run(
        [bin_dir / "python", "-c", DRIVER],
        input=json.dumps(snippets),
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    results = json.loads(done.stdout.splitlines()[-1])  # after fmpy's warnings of inputs left at their start
    for where, outputs in results.items():
        assert outputs, f"{where}: no result"
        assert all(finite for _, _, finite in outputs.values()), (where, outputs)
    (identified,) = [r for where, r in results.items() if where.startswith("docs/identification.md")]
    assert identified["current"][0] == pytest.approx(gains[0] * 80.0, rel=1e-12)
    assert identified["current"][1] == pytest.approx(gains[0] * 80.0, rel=1e-12)
    readme = next(r for where, r in results.items() if where.startswith("README.md"))
    assert readme["current"][0] == pytest.approx(PAPER["gain"] * 100.0, rel=1e-12)


def commands_in_blocks():
    """The commands the user pages' sh blocks run, as installed: {console script} and {module of
    `python -m`}."""
    scripts, modules = set(), set()
    for page in user_pages():
        text = user_text(page)
        for m in FENCE.finditer(text):
            if m.group(1) not in ("sh", "bash", ""):
                continue
            for line in m.group(2).splitlines():
                line = line.strip()
                if found := re.match(r"(aem-[a-z]+)\b", line):
                    scripts.add(found.group(1))
                if found := re.match(r"python -m ([\w.]+)", line):
                    modules.add(found.group(1))
    return scripts, modules


@pytest.mark.slow
def test_the_commands_the_pages_run_are_installed(installed):
    bin_dir, env, work = installed
    scripts, modules = commands_in_blocks()
    assert {"aem-study", "aem-prequalify", "aem-identify"} <= scripts, scripts
    assert "aem_electrolyser.examples.generator_trip" in modules, modules
    for script in sorted(scripts):
        assert (bin_dir / script).is_file(), f"{script}: not installed by the wheel"
    code = (
        "import importlib.util, sys\n"
        "missing = [m for m in sys.argv[1:] if importlib.util.find_spec(m) is None]\n"
        "print(' '.join(missing))\n"
    )
    missing = run([bin_dir / "python", "-c", code, *sorted(modules)], cwd=work, env=env).stdout.split()
    assert not missing, f"python -m of a module the wheel does not have: {missing}"


@pytest.mark.slow
def test_aem_study_writes_and_reads_the_example_study(installed):
    """studies.md: `aem-study --example` lists hub_sizing, `aem-study --example hub_sizing` writes
    hub_sizing.toml into the working folder, and `aem-study hub_sizing.toml --list` reads it (its
    36 scenarios, none stored), without running any."""
    bin_dir, env, work = installed
    folder = work / "study"
    folder.mkdir()
    listed = run([bin_dir / "aem-study", "--example"], cwd=folder, env=env)
    assert "hub_sizing" in listed.stdout + listed.stderr
    run([bin_dir / "aem-study", "--example", "hub_sizing"], cwd=folder, env=env)
    assert (folder / "hub_sizing.toml").is_file(), sorted(p.name for p in folder.iterdir())
    study = tomllib.loads((folder / "hub_sizing.toml").read_text("utf-8"))
    assert "axes" in study and "study" in study
    lines = run([bin_dir / "aem-study", "hub_sizing.toml", "--list"], cwd=folder, env=env).stdout.splitlines()
    assert len(lines) == 36 and all(" to run " in line for line in lines), lines
    assert not (folder / "out").exists()  # nothing ran
