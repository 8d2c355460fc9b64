"""Command-line hygiene of the Python commands, as a new user meets it.

A closed stdout (`python -m aem_electrolyser.examples.step_schedule | head -3`) ends every command quietly with
status 0 (no BrokenPipeError traceback, no "Exception ignored ...") after its result files are
written; an output path that cannot be written ends it at once with status 1 and one line
naming the path, before any long computation. packaging/platforms.py compiles for minutes and
aem_electrolyser.examples.validation_day rebuilds the FMU's library, so of these two only the help and the
argument and output-path errors are run here.
"""

import importlib.util
import sys
import tomllib
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

import pytest

from commands import assert_quiet, run
from conftest import REBUILDS_THE_LIBRARY, ROOT

VALIDATION_HEADER = (
    "time,setpoint,current_measured,current_model,voltage_measured,voltage_model,"
    "power_measured,power_model,h2_flow_measured,h2_flow_model,compared"
)
COMMANDS = [
    ["-m", f"aem_electrolyser.{m}"]
    for m in (
        "examples.step_schedule",
        "examples.cold_start",
        "examples.winter_week",
        "examples.step_responses",
        "examples.validation_day",
        "wind.farm",
        "examples.wind_hub",
        "examples.grid_cosim",
        "plot_validation",
        "reserves.prequalify",
        "reserves.operating_table",
        "reserves.portfolio",
        "study",
    )
] + [
    [script]
    for script in (
        "packaging/package.py",
        "packaging/cross_check.py",
        "packaging/platforms.py",
        "scripts/shrink_png.py",
    )
]
# the console entry points (aem-run and aem-identify: the native commands)
COMMANDS += [[str(Path(sys.executable).parent / name)] for name in ("aem-prequalify", "aem-run", "aem-identify")]


def validation_trace(path):
    """A small CSV in the format of `aem-identify validate --csv`."""
    rows = [VALIDATION_HEADER] + [f"{t},75,40.1,40,42,41.9,1684.2,1676,,376,{int(t >= 60)}" for t in range(120)]
    path.write_text("\n".join(rows) + "\n")
    return path


def small_png(path):
    from PIL import Image

    Image.new("RGB", (40, 30), (200, 120, 40)).save(path)
    return path


def packable_platforms():
    """Platforms whose built library comes from the repository's modelDescription.xml (a build
    from an identified parameter set leaves one that package.py --no-build rightly refuses)."""
    spec = importlib.util.spec_from_file_location("aem_platforms", ROOT / "packaging" / "platforms.py")
    platforms = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(platforms)
    guid = ET.parse(ROOT / "modelDescription.xml").getroot().get("guid").encode()
    found = []
    for name, platform in platforms.PLATFORMS.items():
        library = platforms.release_dir(platform) / platform.library("aem_electrolyser")
        if library.is_file() and guid in library.read_bytes():
            found.append(name)
    return found


def closed_stdout_case(name, tmp, fmu):
    """(arguments with short horizons, result files) of command `name`."""
    if name == "step_schedule":
        return (
            ["-m", "aem_electrolyser.examples.step_schedule", "--fmu", fmu, "--out", tmp / "ss"],
            [tmp / "ss/step_schedule.csv", tmp / "ss/step_schedule.png"],
        )
    if name == "cold_start":
        return (
            ["-m", "aem_electrolyser.examples.cold_start", "--fmu", fmu, "--out", tmp / "cs"],
            [tmp / "cs/cold_start.csv", tmp / "cs/cold_start.png"],
        )
    if name == "winter_week":
        return (
            [
                "-m",
                "aem_electrolyser.examples.winter_week",
                "--fmu",
                fmu,
                "--out",
                tmp / "ww",
                "--days",
                "0.05",
                "--modules",
                "4",
            ],
            [tmp / "ww/winter_week.csv", tmp / "ww/winter_week.png"],
        )
    if name == "step_responses":
        return (
            [
                "-m",
                "aem_electrolyser.examples.step_responses",
                "--fmu",
                fmu,
                "--out",
                tmp,
                "--duration",
                60,
                "--dt",
                1,
                "--dpi",
                40,
            ],
            [tmp / "step_responses.csv", tmp / "step_responses_table.csv", tmp / "step_responses.png"],
        )
    if name == "wind_farm":
        return ["-m", "aem_electrolyser.wind.farm", "--hours", 0.1, "--out", tmp / "wf"], [tmp / "wf/wind_farm.csv"]
    if name == "wind_hub":
        return (
            ["-m", "aem_electrolyser.examples.wind_hub", "--fmu", fmu, "--duration", 60, "--out", tmp / "wh"],
            [tmp / "wh/wind_hub.csv", tmp / "wh/wind_hub.png"],
        )
    if name == "grid_cosim":
        return (
            [
                "-m",
                "aem_electrolyser.examples.grid_cosim",
                "--fmu",
                fmu,
                "--duration",
                1,
                "--gust-start",
                0.2,
                "--out",
                tmp / "gc",
            ],
            [tmp / "gc/grid_cosim.csv", tmp / "gc/grid_cosim.png"],
        )
    if name == "package":
        platforms = packable_platforms()
        if not platforms:
            pytest.skip("no built library comes from modelDescription.xml (python packaging/package.py builds one)")
        return (
            ["packaging/package.py", "--no-build", "--platforms", ",".join(platforms), "--output", tmp / "x.fmu"],
            [tmp / "x.fmu"],
        )
    if name == "cross_check":
        with zipfile.ZipFile(fmu) as z:
            platforms = sorted(
                {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") == 2}
            )
        version = tomllib.loads((ROOT / "Cargo.toml").read_text())["workspace"]["package"]["version"]
        return (
            ["packaging/cross_check.py", "--fmu", fmu, "--out", tmp / "cc"],
            [
                tmp
                / "cc/fmus/2.0/cs"
                / p
                / "aem-electrolyser-fmu"
                / version
                / "AemElectrolyser/AemElectrolyser_ref.csv"
                for p in platforms
            ],
        )
    if name == "plot_validation":
        return ["-m", "aem_electrolyser.plot_validation", validation_trace(tmp / "trace.csv"), tmp / "v.png"], [
            tmp / "v.png"
        ]
    if name == "aem-study":
        (tmp / "flat.csv").write_text("time [s],power [MW]\n0,1\n600,1\n")
        (tmp / "s.toml").write_text(
            f'[study]\nfmu = "{fmu}"\n[axes]\nnModules = [500, 600]\n'
            '[series.flat]\nfile = "flat.csv"\ncolumn = "power [MW]"\n'
        )
        return (
            ["-m", "aem_electrolyser.study", tmp / "s.toml", "--serial", "--out", tmp / "st"],
            [tmp / "st" / name for name in ("kpis.csv", "kpis.parquet", "summary.txt", "plots/hydrogen_kg.png")],
        )
    if name == "shrink_png":
        return ["scripts/shrink_png.py", small_png(tmp / "big.png"), tmp / "small.png"], [tmp / "small.png"]
    raise ValueError(name)


@pytest.mark.parametrize(
    "name",
    [
        "step_schedule",
        "cold_start",
        "winter_week",
        "step_responses",
        "wind_farm",
        "wind_hub",
        "grid_cosim",
        pytest.param("package", marks=REBUILDS_THE_LIBRARY),
        "cross_check",
        "plot_validation",
        "shrink_png",
        "aem-study",
    ],
)
def test_a_closed_stdout_ends_the_command_quietly_after_its_files_are_written(name, tmp_path, fmu_path):
    args, outputs = closed_stdout_case(name, tmp_path, fmu_path)
    assert_quiet(run(args))
    missing = [o for o in outputs if not (o.is_file() and o.stat().st_size > 0)]
    assert outputs and not missing, missing


@pytest.mark.parametrize("name", ["wind_farm", "cross_check"])
def test_a_buffered_stdout_meets_the_closed_pipe_at_exit_quietly(name, tmp_path, fmu_path):
    args, outputs = closed_stdout_case(name, tmp_path, fmu_path)
    assert_quiet(run(args, buffered=True))
    assert all(o.is_file() for o in outputs)


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_help_on_a_closed_stdout_is_quiet(command):
    assert_quiet(run([*command, "--help"], buffered=True))  # argparse itself is quiet when unbuffered


AEM_RUN = str(Path(sys.executable).parent / "aem-run")


def quiet_native(done, status=0):
    """A native command ended with `status`, without a panic ("failed printing to stdout")."""
    assert done.returncode == status, done.stderr
    assert "panicked" not in done.stderr and "failed printing" not in done.stderr, done.stderr


@pytest.mark.parametrize("option", ["--help", "--version"])
def test_aem_run_answers_on_a_closed_stdout_quietly(option):
    quiet_native(run([AEM_RUN, option]))
    assert run([AEM_RUN, option]).stderr == ""


def test_aem_run_ends_as_it_would_have_on_a_closed_stdout(tmp_path, fmu_path):
    """A run whose reader went away ends with the run's status, 0 (its JSON goes nowhere); a
    bad argument still with 2 and its one line on stderr."""
    reference = tmp_path / "reference.f64"
    np.full(10, 3e7, dtype="<f8").tofile(reference)
    quiet_native(run([AEM_RUN, "--fmu", fmu_path, "--reference", reference, "--step", "1"]))
    refused = run([AEM_RUN, "--fmu", fmu_path, "--reference", reference, "--step", "0"])
    quiet_native(refused, status=2)
    assert refused.stderr.startswith("aem-run: error: --step 0"), refused.stderr


def test_platforms_refuses_an_unknown_platform_before_it_builds():
    done = run(["packaging/platforms.py", "aem-identify", "--platforms", "linux64,mac"], timeout=30)
    assert done.returncode == 2, done.stderr
    assert "unknown platform mac" in done.stderr and "Traceback" not in done.stderr, done.stderr


def unwritable_case(name, blocked, tmp, fmu):
    """(arguments with the default, long horizons, extra environment) whose output lies under `blocked`."""
    if name == "platforms":
        return ["packaging/platforms.py", "aem-identify"], {"CARGO_TARGET_DIR": str(blocked)}
    return {
        "step_schedule": ["-m", "aem_electrolyser.examples.step_schedule", "--fmu", fmu, "--out", blocked / "ss"],
        "cold_start": ["-m", "aem_electrolyser.examples.cold_start", "--fmu", fmu, "--out", blocked / "cs"],
        "winter_week": ["-m", "aem_electrolyser.examples.winter_week", "--fmu", fmu, "--out", blocked / "ww"],
        "step_responses": ["-m", "aem_electrolyser.examples.step_responses", "--fmu", fmu, "--out", blocked],
        "validation_day": ["-m", "aem_electrolyser.examples.validation_day", "--out", blocked],
        "wind_farm": ["-m", "aem_electrolyser.wind.farm", "--out", blocked],
        "wind_hub": ["-m", "aem_electrolyser.examples.wind_hub", "--fmu", fmu, "--out", blocked / "wh"],
        "grid_cosim": ["-m", "aem_electrolyser.examples.grid_cosim", "--fmu", fmu, "--out", blocked / "gc"],
        "package": ["packaging/package.py", "--no-build", "--output", blocked / "x.fmu"],
        "cross_check": ["packaging/cross_check.py", "--fmu", fmu, "--out", blocked],
        "plot_validation": [
            "-m",
            "aem_electrolyser.plot_validation",
            validation_trace(tmp / "trace.csv"),
            blocked / "v.png",
        ],
        "shrink_png": ["scripts/shrink_png.py", small_png(tmp / "big.png"), blocked / "small.png"],
    }[name], None


@pytest.mark.parametrize(
    "name",
    [
        "step_schedule",
        "cold_start",
        "winter_week",
        "step_responses",
        "validation_day",
        "wind_farm",
        "wind_hub",
        "grid_cosim",
        "package",
        "cross_check",
        "plot_validation",
        "shrink_png",
        "platforms",
    ],
)
def test_an_unwritable_output_path_fails_fast_with_one_line(name, tmp_path, fmu_path):
    regular_file = tmp_path / "a-file"
    regular_file.write_text("not a folder\n")
    blocked = regular_file / "sub"
    args, env = unwritable_case(name, blocked, tmp_path, fmu_path)
    # The default horizons take minutes (wind_hub, grid_cosim, platforms' build): a check
    # after the computation runs into the timeout.
    done = run(args, stdout_closed=False, timeout=30, env=env)
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and str(blocked) in lines[0] and "cannot write" in lines[0], done.stderr
    assert "Traceback" not in done.stderr
