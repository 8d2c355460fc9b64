"""The command-line convention (aem_electrolyser.cli) of every command, on bad input.

A bad argument is refused before any work: exit status 2, exactly one non-empty line on stderr,
`<program>: error: ...`, naming the option (or the positional, or the study file's key, or the
environment variable AEM_FMU) and, where a near name exists, "did you mean" it; no traceback anywhere, and no result file or folder
written (tmp_path holds afterwards exactly the inputs the test wrote). `--out` names a folder: an
existing regular file there is a bad argument like any other (status 2, one line naming it). A failure
during the work is status 1 and one line, "(--debug shows the traceback)"; `--debug` shows it.

Every case is a refusal before any work (or a failure at the FMU's instantiation), so each runs in
about a second, the commands that import pandapower or Dask before parsing in about three.
"""

import os
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest

import aem_electrolyser
from conftest import ROOT

BIN = Path(sys.executable).parent


def module(name):
    return [sys.executable, "-m", f"aem_electrolyser.{name}"], f"python -m aem_electrolyser.{name}"


def script(name):
    return [str(BIN / name)], name


#: command -> (argv prefix, the program name its error lines start with)
PROGRAMS = {
    "step_schedule": module("examples.step_schedule"),
    "cold_start": module("examples.cold_start"),
    "winter_week": module("examples.winter_week"),
    "step_responses": module("examples.step_responses"),
    "validation_day": module("examples.validation_day"),
    "wind_hub": module("examples.wind_hub"),
    "grid_cosim": module("examples.grid_cosim"),
    "generator_trip": module("examples.generator_trip"),
    "cigre_scenario": module("mosaik.cigre_scenario"),
    "helics.run": module("helics.run"),
    "wind.farm": module("wind.farm"),
    "wind.year": module("wind.year"),
    "plot_validation": module("plot_validation"),
    "aem-prequalify": script("aem-prequalify"),
    "operating_table": module("reserves.operating_table"),
    "portfolio": module("reserves.portfolio"),
    "aem-study": script("aem-study"),
    "aem-identify": script("aem-identify"),
    "aem-run": script("aem-run"),
}

OUT = ["--out", "{out}"]


def case(command, kind, argv, says, status=2, near=None, env=None, unsaid=()):
    """One row: `command` given `argv` (templates over the `inputs` fixture's paths), and `env`
    in its environment, is refused with `status` and one line that contains each of `says`,
    none of `unsaid` and, if `near`, "did you mean" it.
    """
    return pytest.param(command, argv, status, says, near, env or {}, unsaid, id=f"{command}:{kind}")


def aem_fmu_cases(command, *argv):
    """The environment variable AEM_FMU naming no file, or a text file, with no --fmu given:
    the line blames AEM_FMU, not --fmu."""
    return [
        case(
            command,
            "aem-fmu-missing",
            list(argv),
            ["AEM_FMU", "/no/such.fmu", "no such FMU"],
            env={"AEM_FMU": "/no/such.fmu"},
            unsaid=["--fmu"],
        ),
        case(
            command,
            "aem-fmu-text-file",
            list(argv),
            ["AEM_FMU", "{text_fmu}", "is not an FMU"],
            env={"AEM_FMU": "{text_fmu}"},
            unsaid=["--fmu"],
        ),
    ]


def fmu_cases(command, *extra):
    """--fmu missing, --fmu a text file, --fmu a zip archive without modelDescription.xml."""
    return [
        case(command, "fmu-missing", ["--fmu", "/no/such.fmu", *extra, *OUT], ["--fmu", "/no/such.fmu", "no such FMU"]),
        case(command, "fmu-text-file", ["--fmu", "{text_fmu}", *extra, *OUT], ["--fmu", "{text_fmu}", "is not an FMU"]),
        case(
            command,
            "fmu-zip-without-model-description",
            ["--fmu", "{zip_fmu}", *extra, *OUT],
            ["--fmu", "{zip_fmu}", "is not an FMU", "modelDescription.xml"],
        ),
    ]


def out_file_case(command, status=2, *extra):
    """--out an existing regular file (the file is left as it was)."""
    return case(
        command, "out-is-a-file", [*extra, "--out", "{file}"], ["--out", "{file}", "names a folder"], status=status
    )


TABLE = [
    # --- examples.step_schedule: --fmu, --out only
    *fmu_cases("step_schedule"),
    *aem_fmu_cases("step_schedule", *OUT),
    case("step_schedule", "misspelled-option", ["--fum", "x", *OUT], ["unknown option --fum"], near="--fmu"),
    out_file_case("step_schedule"),
    # --- examples.cold_start: --fmu, --out only
    *fmu_cases("cold_start"),
    case("cold_start", "misspelled-option", ["--fum", "x", *OUT], ["unknown option --fum"], near="--fmu"),
    out_file_case("cold_start"),
    # --- examples.winter_week
    *fmu_cases("winter_week"),
    case("winter_week", "modules-0", ["--modules", "0", *OUT], ["--modules", "positive"]),
    case("winter_week", "days-negative", ["--days", "-1", *OUT], ["--days", "positive"]),
    case("winter_week", "days-too-short", ["--days", "0.0001", *OUT], ["--days", "shorter than two 60 s steps"]),
    case(
        "winter_week", "misspelled-option", ["--modueles", "3", *OUT], ["unknown option --modueles"], near="--modules"
    ),
    out_file_case("winter_week"),
    # --- examples.step_responses
    *fmu_cases("step_responses"),
    case("step_responses", "duration-0", ["--duration", "0", *OUT], ["--duration", "positive"]),
    case("step_responses", "duration-negative", ["--duration", "-5", *OUT], ["--duration", "positive"]),
    case("step_responses", "dt-0", ["--dt", "0", *OUT], ["--dt", "positive"]),
    case(
        "step_responses", "misspelled-option", ["--duraton", "5", *OUT], ["unknown option --duraton"], near="--duration"
    ),
    out_file_case("step_responses"),
    # --- examples.validation_day (no --fmu: it builds its own; --tool is its input)
    case(
        "validation_day", "tool-missing", ["--tool", "/no/such/aem-identify", *OUT], ["--tool", "/no/such/aem-identify"]
    ),
    case("validation_day", "days-0", ["--days", "0", *OUT], ["--days", "positive"]),
    case("validation_day", "hours-0", ["--hours", "0", *OUT], ["--hours", "positive"]),
    case("validation_day", "misspelled-option", ["--dais", "3", *OUT], ["unknown option --dais"], near="--days"),
    out_file_case("validation_day"),
    # --- examples.wind_hub
    *fmu_cases("wind_hub"),
    case("wind_hub", "hours-0", ["--hours", "0", *OUT], ["--hours", "positive"]),
    case("wind_hub", "duration-0", ["--duration", "0", *OUT], ["--duration", "positive"]),
    case("wind_hub", "duration-negative", ["--duration", "-5", *OUT], ["--duration", "positive"]),
    # the hub runs whole 1 s steps: 10.5 s is not run as 10 s
    case("wind_hub", "duration-not-whole-steps", ["--duration", "10.5", *OUT], ["--duration", "10.5 s", "whole"]),
    case("wind_hub", "hours-not-whole-steps", ["--hours", "0.0031", *OUT], ["--hours", "11.16 s", "whole"]),
    case("wind_hub", "misspelled-option", ["--duraton", "5", *OUT], ["unknown option --duraton"], near="--duration"),
    out_file_case("wind_hub"),
    # --- examples.grid_cosim
    *fmu_cases("grid_cosim"),
    case("grid_cosim", "duration-0", ["--duration", "0", *OUT], ["--duration", "positive"]),
    case("grid_cosim", "duration-negative", ["--duration", "-5", *OUT], ["--duration", "positive"]),
    case("grid_cosim", "exchange-0", ["--exchange", "0", *OUT], ["--exchange", "positive"]),
    case("grid_cosim", "misspelled-option", ["--duraton", "5", *OUT], ["unknown option --duraton"], near="--duration"),
    out_file_case("grid_cosim"),
    # --- examples.generator_trip
    *fmu_cases("generator_trip"),
    case("generator_trip", "duration-0", ["--duration", "0", *OUT], ["--duration", "positive"]),
    case("generator_trip", "modules-0", ["--modules", "0", *OUT], ["--modules", "positive"]),
    case("generator_trip", "modules-negative", ["--modules", "-1000", *OUT], ["--modules", "positive"]),
    case(
        "generator_trip", "misspelled-option", ["--duraton", "5", *OUT], ["unknown option --duraton"], near="--duration"
    ),
    out_file_case("generator_trip"),
    # --- mosaik.cigre_scenario
    *fmu_cases("cigre_scenario"),
    case("cigre_scenario", "duration-0", ["--duration", "0", *OUT], ["--duration", "positive"]),
    case("cigre_scenario", "duration-negative", ["--duration", "-5", *OUT], ["--duration", "positive"]),
    case("cigre_scenario", "dispatch-unknown", ["--dispatch", "eqaul", *OUT], ["--dispatch", "'eqaul'"], near="equal"),
    case(
        "cigre_scenario", "misspelled-option", ["--duraton", "5", *OUT], ["unknown option --duraton"], near="--duration"
    ),
    out_file_case("cigre_scenario"),
    # --- helics.run
    *fmu_cases("helics.run"),
    case("helics.run", "duration-0", ["--duration", "0", *OUT], ["--duration", "positive"]),
    case("helics.run", "duration-negative", ["--duration", "-5", *OUT], ["--duration", "positive"]),
    case("helics.run", "modules-0", ["--modules", "0", *OUT], ["--modules", "positive"]),
    case("helics.run", "modules-negative", ["--modules", "-1000", *OUT], ["--modules", "positive"]),
    case("helics.run", "dispatch-unknown", ["--dispatch", "eqaul", *OUT], ["--dispatch", "'eqaul'"], near="equal"),
    case("helics.run", "misspelled-option", ["--duraton", "5", *OUT], ["unknown option --duraton"], near="--duration"),
    out_file_case("helics.run"),
    # --- wind.farm, wind.year
    case("wind.farm", "hours-0", ["--hours", "0", *OUT], ["--hours", "positive"]),
    case("wind.farm", "misspelled-option", ["--huors", "1", *OUT], ["unknown option --huors"], near="--hours"),
    out_file_case("wind.farm"),
    case("wind.year", "days-0", ["--days", "0", *OUT], ["--days", "positive"]),
    case("wind.year", "dt-0", ["--dt", "0", *OUT], ["--dt", "positive"]),
    case("wind.year", "misspelled-option", ["--day", "1", *OUT], ["unknown option --day"], near="--days"),
    out_file_case("wind.year"),
    # --- plot_validation CSV PNG (the PNG in {out}: its folder must not be made)
    case("plot_validation", "csv-missing", ["/no/such.csv", "{out}/validation.png"], ["csv", "/no/such.csv"]),
    case(
        "plot_validation",
        "csv-of-another-kind",
        ["{file}", "{out}/validation.png"],
        ["csv", "{file}", "current_measured", "compared", "aem-identify validate --csv"],
        unsaid=["KeyError"],
    ),
    case(
        "plot_validation",
        "misspelled-option",
        ["--dbug", "{file}", "{out}/validation.png"],
        ["unknown option --dbug"],
        near="--debug",
    ),
    # --- aem-prequalify
    *fmu_cases("aem-prequalify"),
    *aem_fmu_cases("aem-prequalify", *OUT),
    case("aem-prequalify", "modules-0", ["--modules", "0", *OUT], ["--modules", "positive"]),
    case("aem-prequalify", "modules-negative", ["--modules", "-1000", *OUT], ["--modules", "positive"]),
    case("aem-prequalify", "dispatch-unknown", ["--dispatch", "eqaul", *OUT], ["--dispatch", "'eqaul'"], near="equal"),
    case(
        "aem-prequalify",
        "products-unknown",
        ["--products", "FCR-D upp", *OUT],
        ["--products", "'FCR-D upp'"],
        near="FCR-D up",
    ),
    case(
        "aem-prequalify",
        "compensation-unknown",
        ["--compensation", "maybe", *OUT],
        ["--compensation", "'maybe'", "off, on, both"],
    ),
    case(
        "aem-prequalify",
        "compensation-near-miss",
        ["--compensation", "bot", *OUT],
        ["--compensation", "'bot'"],
        near="both",
    ),
    case("aem-prequalify", "dt-0", ["--dt", "0", *OUT], ["--dt", "positive"]),
    case("aem-prequalify", "workers-0", ["--workers", "0", *OUT], ["--workers", "positive"]),
    # --jobs, the name before --workers, is still taken (and its value checked), but not suggested
    case("aem-prequalify", "jobs-0-the-old-spelling", ["--jobs", "0", *OUT], ["--jobs", "positive"]),
    case(
        "aem-prequalify", "misspelled-workers", ["--wrokers", "2", *OUT], ["unknown option --wrokers"], near="--workers"
    ),
    case("aem-prequalify", "misspelled-jobs", ["--jbos", "2", *OUT], ["unknown option --jbos"], unsaid=["--jobs"]),
    # the product names in any case: the refusal is --dt's, after --products was taken
    case("aem-prequalify", "products-in-any-case", ["--products", "fcr-d UP,afrr up", "--dt", "0", *OUT], ["--dt"]),
    case(
        "aem-prequalify",
        "products-near-miss-in-another-case",
        ["--products", "fcr-d upp", *OUT],
        ["--products", "'fcr-d upp'"],
        near="FCR-D up",
    ),
    # equal dispatch, the default, cannot hold 50 %: sequential dispatch is what is wanted
    case(
        "aem-prequalify",
        "optimise-dispatch-baseline-below-equal-dispatch",
        ["--modules", "10", "--optimise-dispatch", "--baseline", "50", *OUT],
        ["--baseline", "50 %", "equal dispatch", "give --dispatch sequential"],
    ),
    case(
        "aem-prequalify", "misspelled-option", ["--modulse", "10", *OUT], ["unknown option --modulse"], near="--modules"
    ),
    out_file_case("aem-prequalify"),
    # --- reserves.operating_table, reserves.portfolio: --workers as aem-prequalify's
    case("operating_table", "workers-0", ["--workers", "0", *OUT], ["--workers", "positive"]),
    case("operating_table", "jobs-0-the-old-spelling", ["--jobs", "0", *OUT], ["--jobs", "positive"]),
    case("portfolio", "workers-0", ["--workers", "0", *OUT], ["--workers", "positive"]),
    case("portfolio", "jobs-0-the-old-spelling", ["--jobs", "0", *OUT], ["--jobs", "positive"]),
    # --- aem-study STUDY.toml
    case(
        "aem-study",
        "study-file-missing",
        ["{tmp}/no_such_study.toml", "--serial", *OUT],
        ["{tmp}/no_such_study.toml", "no such study file"],
    ),
    case(
        "aem-study",
        "misspelled-axis",
        ["{hub_sise}", "--serial", *OUT],
        ["{hub_sise}", "[axes]", "'hub_sise'", "valid axes: series, seed, hub_size, step, horizon", "nModules"],
        near="hub_size",
    ),
    case(
        "aem-study",
        "misspelled-key",
        ["{horizn}", "--serial", *OUT],
        ["{horizn}", "[study]", "'horizn'"],
        near="horizon",
    ),
    case("aem-study", "misspelled-table", ["{axis_table}", "--serial", *OUT], ["{axis_table}", "[axis]"], near="axes"),
    case("aem-study", "hub-size-0", ["{hub_size_0}", "--serial", *OUT], ["{hub_size_0}", "[axes] hub_size", "0"]),
    case(
        "aem-study",
        "study-fmu-missing",
        ["{fmu_missing_study}", "--serial", *OUT],
        ["{fmu_missing_study}", "[study] fmu", "/no/such.fmu"],
    ),
    case(
        "aem-study",
        "study-fmu-text-file",
        ["{fmu_text_study}", "--serial", *OUT],
        ["{fmu_text_study}", "[study] fmu", "{text_fmu}", "is not an FMU"],
    ),
    case(
        "aem-study",
        "study-fmu-zip-without-model-description",
        ["{fmu_zip_study}", "--serial", *OUT],
        ["{fmu_zip_study}", "[study] fmu", "{zip_fmu}", "is not an FMU"],
    ),
    case("aem-study", "workers-0", ["{study}", "--workers", "0", *OUT], ["--workers", "positive"]),
    case(
        "aem-study",
        "misspelled-option",
        ["{study}", "--wrokers", "2", *OUT],
        ["unknown option --wrokers"],
        near="--workers",
    ),
    out_file_case("aem-study", 2, "{study}", "--serial"),
    case(
        "aem-study",
        "runner-not-a-program",
        ["{study}", "--runner", "{text_fmu}", "--serial", *OUT],
        ["--runner", "{text_fmu}", "is not a program"],
    ),
    case(
        "aem-study",
        "series-column-missing",
        ["{series_column_missing}", "--serial", *OUT],
        ["{series_column_missing}", "[series.site] time: no column 'time [s]'", "{file}", "its columns: "],
    ),
    case(
        "aem-study",
        "example-near-miss",
        ["--example", "hub_sizng", "--out", "{out}/study.toml"],
        ["--example", "'hub_sizng'", "examples: hub_sizing"],
        near="hub_sizing",
    ),
    case("aem-study", "example-over-a-file", ["--example", "hub_sizing", "--out", "{file}"], ["{file}", "exists"]),
    # --- aem-identify fit|validate|synthesize (the results: fit -o FILE, validate --csv FILE, synthesize DIR)
    case(
        "aem-identify",
        "fit-input-missing",
        ["fit", "/no/such.csv", "-o", "{out}/params.json"],
        ["input", "/no/such.csv"],
    ),
    case(
        "aem-identify",
        "validate-parameter-file-missing",
        ["validate", "/no/such.json", "{file}", "--csv", "{out}/validation.csv"],
        ["parameter file", "/no/such.json"],
    ),
    case(
        "aem-identify",
        "validate-day-missing",
        ["validate", "{file}", "/no/such.csv", "--csv", "{out}/validation.csv"],
        ["held-out day", "/no/such.csv"],
    ),
    case("aem-identify", "synthesize-days-0", ["synthesize", "{out}", "--days", "0"], ["--days 0"]),
    case("aem-identify", "synthesize-hours-0", ["synthesize", "{out}", "--hours", "0"], ["--hours 0"]),
    case("aem-identify", "misspelled-option", ["synthesize", "{out}", "--dasy", "3"], ["'--dasy'"], near="--days"),
    case("aem-identify", "misspelled-subcommand", ["synthesise", "{out}"], ["'synthesise'"], near="synthesize"),
    case(
        "aem-identify",
        "synthesize-into-a-file",
        ["synthesize", "{file}", "--days", "1"],
        ["{file}", "cannot write"],
        status=1,
    ),
    case("aem-identify", "synthesize-hours-negative", ["synthesize", "{out}", "--hours", "-1"], ["--hours"]),
    case("aem-identify", "fit-max-gap-0", ["fit", "{file}", "--max-gap", "0"], ["--max-gap"]),
    case("aem-identify", "fit-separator-unknown", ["fit", "{file}", "--separator", "banana"], ["--separator"]),
    case("aem-identify", "fit-cells-0", ["fit", "{campaign}", "--cells", "0"], ["--cells"]),
    # --- aem-run (prints the JSON for a worker on stdout as well; no result files)
    case("aem-run", "step-0", ["--reference", "{reference}", "--step", "0"], ["--step 0", "positive"]),
    case("aem-run", "step-negative", ["--reference", "{reference}", "--step", "-1"], ["--step -1", "positive"]),
    case(
        "aem-run",
        "misspelled-option",
        ["--reference", "{reference}", "--stpe", "1"],
        ["unknown argument --stpe"],
        near="--step",
    ),
    case(
        "aem-run", "reference-missing", ["--reference", "/no/such.f64", "--step", "1"], ["--reference", "/no/such.f64"]
    ),
    case(
        "aem-run",
        "fmu-missing",
        ["--fmu", "/no/such.fmu", "--reference", "{reference}", "--step", "1"],
        ["--fmu", "/no/such.fmu"],
    ),
    case(
        "aem-run",
        "fmu-text-file",
        ["--fmu", "{text_fmu}", "--reference", "{reference}", "--step", "1"],
        ["--fmu", "{text_fmu}"],
    ),
    case(
        "aem-run",
        "fmu-zip-without-model-description",
        ["--fmu", "{zip_fmu}", "--reference", "{reference}", "--step", "1"],
        ["--fmu", "{zip_fmu}"],
    ),
    case(
        "aem-run",
        "parameter-misspelled",
        ["--reference", "{reference}", "--step", "1", "--parameter", "nModlues=10"],
        ["--parameter", "nModlues"],
        near="nModules",
    ),
    # --param, the name before --parameter (aem-study's workers give it), is still taken
    case(
        "aem-run",
        "param-the-old-spelling-misspelled",
        ["--reference", "{reference}", "--step", "1", "--param", "nModlues=10"],
        ["--parameter", "nModlues"],
        near="nModules",
    ),
    case(
        "aem-run",
        "misspelled-parameter-option",
        ["--reference", "{reference}", "--step", "1", "--paramter", "nModules=10"],
        ["unknown argument --paramter"],
        near="--parameter",
    ),
    *aem_fmu_cases("aem-run", "--reference", "{reference}", "--step", "1"),
]

STUDY = '[study]\ntitle = "command line"\nfmu = "{fmu}"\nhorizon = "10 s"\nstep = "1 s"\n'
WIND = '[series.wind]\ngenerator = "wind"\n'
STUDIES = {
    "study": STUDY + WIND + "[axes]\nseed = [1]\n",
    "hub_sise": STUDY + WIND + "[axes]\nseed = [1]\nhub_sise = [40, 60]\n",
    "horizn": STUDY.replace("horizon", "horizn") + WIND + "[axes]\nseed = [1]\n",
    "axis_table": STUDY + WIND + "[axis]\nseed = [1]\n",
    "hub_size_0": STUDY + WIND + "[axes]\nhub_size = [40, 0]\n",
    "series_column_missing": STUDY + '[series.site]\nfile = "existing_file"\ncolumn = "power [MW]"\n',
}


@pytest.fixture
def inputs(tmp_path, fmu_path):
    """Every input a case may name, written into tmp_path; {name: path as text}."""
    paths = {"tmp": str(tmp_path), "out": str(tmp_path / "out")}
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    (inputs / "text.fmu").write_text("this is not an FMU\n")
    with zipfile.ZipFile(inputs / "no_model_description.fmu", "w") as z:
        z.writestr("documentation/index.html", "<html></html>\n")
    (inputs / "existing_file").write_text("left as it was\n")
    np.full(10, 3e7, dtype="<f8").tofile(inputs / "reference.f64")
    paths.update(
        text_fmu=str(inputs / "text.fmu"),
        zip_fmu=str(inputs / "no_model_description.fmu"),
        file=str(inputs / "existing_file"),
        reference=str(inputs / "reference.f64"),
    )
    for name, body in {
        **STUDIES,
        "fmu_missing_study": STUDIES["study"].replace("{fmu}", "/no/such.fmu"),
        "fmu_text_study": STUDIES["study"].replace("{fmu}", paths["text_fmu"]),
        "fmu_zip_study": STUDIES["study"].replace("{fmu}", paths["zip_fmu"]),
    }.items():
        (inputs / f"{name}.toml").write_text(body.replace("{fmu}", str(fmu_path)))
        paths[name] = str(inputs / f"{name}.toml")
    return paths


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Two synthetic days (aem-identify synthesize), outside the cases' tmp_path."""
    folder = tmp_path_factory.mktemp("campaign") / "days"
    done = subprocess.run(
        [str(BIN / "aem-identify"), "synthesize", str(folder), "--days", "2", "--hours", "1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    return str(folder)


def contents(folder):
    """Every path under `folder` with, for files, its size and modification time."""
    return {
        str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns) if p.is_file() else None
        for p in folder.rglob("*")
    }


def run(argv, timeout=60, env=None):
    env = {**os.environ, **env} if env else None
    return subprocess.run([str(a) for a in argv], cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=env)


def one_line(done, program):
    """The single non-empty line of stderr, which starts with `<program>: error: `; no traceback."""
    shown = f"exit {done.returncode}\nstderr:\n{done.stderr}\nstdout:\n{done.stdout[-2000:]}"
    assert "Traceback" not in done.stderr and "Traceback" not in done.stdout, shown
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, shown
    assert lines[0].startswith(f"{program}: error: "), shown
    return lines[0], shown


@pytest.mark.parametrize("command, argv, status, says, near, env, unsaid", TABLE)
def test_a_bad_argument_is_one_line_before_any_work(
    request, tmp_path, inputs, command, argv, status, says, near, env, unsaid
):
    if any("{campaign}" in a for a in argv):
        inputs = {**inputs, "campaign": request.getfixturevalue("campaign")}
    before = contents(tmp_path)
    prefix, program = PROGRAMS[command]
    env = {name: value.format(**inputs) for name, value in env.items()}
    done = run([*prefix, *(a.format(**inputs) for a in argv)], env=env)
    line, shown = one_line(done, program)
    assert done.returncode == status, shown
    for words in says:
        assert words.format(**inputs) in line, (words, line)
    for words in unsaid:
        assert words.format(**inputs) not in line, (words, line)
    if near:
        assert re.search(rf"did you mean '?{re.escape(near)}'?\?", line), (near, line)
    assert contents(tmp_path) == before, "result files were written"


# --- a failure during the work -------------------------------------------------------------------


def guid_mismatch(fmu_path, path):
    """The FMU with another GUID in its model description: the binary refuses to instantiate."""
    with zipfile.ZipFile(fmu_path) as z, zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            data = z.read(item)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'guid="[^"]*"', b'guid="{00000000-0000-0000-0000-000000000000}"', data)
            out.writestr(item, data)
    return path


FAILING_TOOL = '#!/bin/sh\necho "the disk is full" >&2\nexit 3\n'

FAILURES = [
    pytest.param(
        "wind_hub",
        ["--fmu", "{guid_fmu}", "--duration", "2", *OUT],
        "does not match the model description",
        id="wind_hub:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "aem-prequalify",
        [
            "--fmu",
            "{guid_fmu}",
            "--modules",
            "10",
            "--products",
            "mFRR up",
            "--compensation",
            "off",
            "--jobs",
            "1",
            "--no-plots",
            *OUT,
        ],
        "does not match the model description",
        id="aem-prequalify:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "operating_table",
        # two cells: their searches run side by side, and the first failure ends both
        ["--fmu", "{guid_fmu}", "--modules", "10", "--baseline", "80,90", "--products", "aFRR up", "--no-plots", *OUT],
        "does not match the model description",
        id="operating_table:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "validation_day",
        ["--tool", "{failing_tool}", "--days", "1", *OUT],
        "the disk is full",
        id="validation_day:aem-identify-fails",
    ),
    pytest.param(
        "step_schedule",
        ["--fmu", "{guid_fmu}", *OUT],
        "does not match the model description",
        id="step_schedule:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "cold_start",
        ["--fmu", "{guid_fmu}", *OUT],
        "does not match the model description",
        id="cold_start:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "winter_week",
        ["--fmu", "{guid_fmu}", "--days", "0.01", *OUT],
        "does not match the model description",
        id="winter_week:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "step_responses",
        ["--fmu", "{guid_fmu}", "--duration", "2", *OUT],
        "does not match the model description",
        id="step_responses:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "cigre_scenario",
        ["--fmu", "{guid_fmu}", "--duration", "2", *OUT],
        "does not match the model description",
        id="cigre_scenario:fmu-refuses-to-instantiate",
    ),
    pytest.param(
        "plot_validation", ["{empty_csv}", "{out}/validation.png"], "no rows", id="plot_validation:csv-without-rows"
    ),
]


@pytest.mark.parametrize("command, argv, says", FAILURES)
def test_a_failure_during_the_work_is_one_line_and_debug_shows_the_traceback(tmp_path, fmu_path, command, argv, says):
    tool = tmp_path / "failing-aem-identify"
    tool.write_text(FAILING_TOOL)
    tool.chmod(0o755)
    (tmp_path / "empty.csv").write_text("")
    paths = {
        "out": str(tmp_path / "out"),
        "guid_fmu": str(guid_mismatch(fmu_path, tmp_path / "guid.fmu")),
        "failing_tool": str(tool),
        "empty_csv": str(tmp_path / "empty.csv"),
    }
    prefix, program = PROGRAMS[command]
    argv = [*prefix, *(a.format(**paths) for a in argv)]

    done = run(argv)
    line, shown = one_line(done, program)
    assert done.returncode == 1, shown
    assert says in line and line.endswith("(--debug shows the traceback)"), shown

    debug = run([*argv, "--debug"])
    assert debug.returncode == 1 and "Traceback (most recent call last)" in debug.stderr, debug.stderr


# --- what a command answers besides its work -------------------------------------------------------

CARGO_VERSION = tomllib.loads((ROOT / "Cargo.toml").read_text())["workspace"]["package"]["version"]


@pytest.mark.parametrize(
    "command, name",
    [
        ("aem-run", "aem-run"),
        ("aem-identify", "aem-identify"),
        ("aem-prequalify", "aem-prequalify"),
        ("operating_table", "python -m aem_electrolyser.reserves.operating_table"),
        ("portfolio", "python -m aem_electrolyser.reserves.portfolio"),
    ],
)
def test_a_command_tells_its_version(command, name):
    """`--version`: the program and the workspace's version (the package's, the FMU's), status 0."""
    prefix, _ = PROGRAMS[command]
    done = run([*prefix, "--version"], env={"AEM_FMU": "/no/such.fmu"})  # no FMU needed
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert done.stdout.strip() == f"{name} {CARGO_VERSION}"
    assert aem_electrolyser.__version__ == CARGO_VERSION


#: Makes the modules of an extra uninstallable in a fresh interpreter, as in an installation
#: without the extra (extras.missing finds them missing; importing one fails), then runs the
#: command's entry point with the arguments given.
WITHOUT = """
import importlib.abc, sys
BLOCKED = {blocked!r}
class Blocker(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
sys.meta_path.insert(0, Blocker())
sys.argv = [{command!r}, *{argv!r}]
from aem_electrolyser.commands import {entry}
{entry}()
"""

#: command -> (its entry point in aem_electrolyser.commands, the modules of its extra that are
#: not dependencies of the package itself)
ENTRY_POINTS = {
    "aem-prequalify": ("prequalify", ["matplotlib"]),
    "aem-study": ("study", ["distributed", "dask", "pyarrow", "pandas", "matplotlib"]),
}


def without_extra(command, *argv):
    entry, blocked = ENTRY_POINTS[command]
    code = WITHOUT.format(blocked=blocked, command=command, argv=list(argv), entry=entry)
    return run([sys.executable, "-c", code])


@pytest.mark.parametrize("command", ENTRY_POINTS)
def test_help_needs_no_extra(command):
    """--help is shown without the command's extra (its parser imports none of its packages);
    the command itself still ends with the extra's one line."""
    done = without_extra(command, "--help")
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert done.stdout.startswith(f"usage: {command}"), done.stdout
    work = without_extra(command, "--out", "/no/such/folder")
    assert work.returncode == 1 and "Traceback" not in work.stderr, work.stderr
    assert work.stderr.startswith(f"{command} needs the ["), work.stderr


def test_prequalify_version_needs_no_extra():
    done = without_extra("aem-prequalify", "--version")
    assert done.returncode == 0 and done.stdout.strip() == f"aem-prequalify {CARGO_VERSION}", done.stderr


def test_hub_driver_takes_enumerations_by_the_names_the_model_description_declares(fmu_path):
    """HubFMU(dispatch="sequential"), as study files take it; a near miss is one line."""
    from aem_electrolyser.hub.driver import HubFMU

    hub = HubFMU(fmu_path, nModules=10, dispatch="sequential", belowMinimum="standby")
    try:
        hub.initialize()
        assert hub.get("dispatch", "belowMinimum") == [2, 1]
    finally:
        hub.close()
    with pytest.raises(ValueError, match=r"dispatch = 'sequentail': not one of equal, .*did you mean 'sequential'\?"):
        HubFMU(fmu_path, nModules=10, dispatch="sequentail")


def readme_snippet():
    """The README's "Use the FMU" example."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return re.search(r"## Use the FMU\s+```python\n(.*?)```", text, re.S).group(1)


def test_the_readme_example_runs_without_warnings(capfd, fmu_path):
    """The README's first example prints nothing (fmpy warns of every input the input array
    leaves out), and simulates what the setpoint alone gives."""
    from fmpy import simulate_fmu

    names = {}
    exec(readme_snippet(), names)  # noqa: S102 - the README's own example
    printed = capfd.readouterr()
    assert printed.out == "" and printed.err == "", printed
    steps = np.array([(0, 100.0), (60, 100.0), (60, 60.0), (600, 60.0)], dtype=[("time", float), ("setpoint", float)])
    alone = simulate_fmu(
        str(fmu_path), stop_time=600, output_interval=1, input=steps, output=["current", "voltage", "power", "h2Flow"]
    )
    capfd.readouterr()
    for name in ("time", "current", "voltage", "power", "h2Flow"):
        np.testing.assert_array_equal(names["result"][name], alone[name])
