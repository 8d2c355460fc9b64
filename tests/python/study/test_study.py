"""aem-study end to end: study files in tmp_path, the packaged FMU driven by aem-run, serial
and on a real Dask LocalCluster (worker processes on the loopback).

Expectations: closed-form KPIs of an equal hub at a constant reference, the serial run for
the cluster's (bit for bit), the FMU's own messages for refused parameters, the store's
contents for stopped, resumed and worker-killed studies, and the command-line convention
(aem_electrolyser.cli): a wrong argument or study file is one line on stderr, status 2, before
anything runs; a failure of the run one line, status 1."""

import json
import math
import os
import pickle
import signal
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import PAPER, module_power, setpoint_for

from aem_electrolyser import locate
from aem_electrolyser.study import cli, engine, progress
from aem_electrolyser.study.definition import Study
from aem_electrolyser.study.kpis import KPIS
from aem_electrolyser.study.series import reference
from aem_electrolyser.study.table import table
from aem_electrolyser.study.worker import RunnerKilled, run_scenario

BIN = Path(sys.executable).parent
RUNNER = locate.binary("aem-run")
AEM_STUDY = [str(BIN / "aem-study")]  # the installed command
#: kg per normal litre of hydrogen: M(H2) / V_m(0 °C, 1 atm) = 2.01588 g/mol / 22.413969545 l/mol.
KG_PER_NL = 2.01588e-3 / 22.413969545014137
#: Two sequential-dispatch cases (sequential needs standby or off below the minimum).
MODES = """
[axes.mode]
equal = { dispatch = "equal", belowMinimum = "stayAtMinimum" }
sequential = { dispatch = "sequential", belowMinimum = "standby" }
"""


@pytest.fixture(autouse=True)
def runner_built(fmu_path):
    if not RUNNER.is_file():
        pytest.fail(f"{RUNNER} not found: cargo build --release --bins")


def write_study(folder, body, fmu_path):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "study.toml"
    path.write_text(f'[study]\ntitle = "test"\nfmu = "{fmu_path}"\n' + body)
    return path


def run_study(path, out, **kwargs):
    study = Study(path)
    records = engine.run(study, out, runner=RUNNER, **kwargs)
    return study, table(study.scenarios(), study.axis_columns, records)


def kpi_values(frame):
    return frame[list(KPIS)].to_numpy(dtype=float)


def test_constant_power_gives_the_closed_form_kpis(tmp_path, fmu_path):
    n, hub_power, hours = 400, 0.8e6, 2.0  # 2 kW per module: inside 60…100 %
    (tmp_path / "flat.csv").write_text(f"time [s],power [kW]\n0,{hub_power / 1e3}\n{hours * 3600},{hub_power / 1e3}\n")
    path = write_study(
        tmp_path,
        f"""horizon = "{hours} h"
[parameters]
nModules = {n}
[series.flat]
file = "flat.csv"
column = "power [kW]"
""",
        fmu_path,
    )
    _, frame = run_study(path, tmp_path / "out", serial=True)
    row = frame.iloc[0]
    assert row["status"] == "done", row["message"]
    t = hours * 3600.0
    current = PAPER["gain"] * setpoint_for(hub_power / n)  # A per module
    rated = n * module_power(PAPER["maxSetpoint"])
    expected = {
        "modules [1]": n,
        "horizon [h]": hours,
        "reference energy [MWh]": hub_power * t / 3.6e9,
        "energy drawn [MWh]": hub_power * t / 3.6e9,  # E = P t
        "grid energy [MWh]": hub_power * t / 3.6e9,  # no supply losses, no auxiliaries
        "supply losses and auxiliaries [MWh]": 0.0,
        "hydrogen [kg]": n * PAPER["h2Coefficient"] * current * hours * KG_PER_NL,  # c I t
        "hub rated power [MW]": rated / 1e6,
        "full-load hours [h]": hub_power * hours / rated,
        "wind not absorbed [MWh]": 0.0,
        "grid import [MWh]": 0.0,
        "starts per module [1]": 0.0,
        "warm starts per module [1]": 0.0,
        "cold starts per module [1]": 0.0,
        "running hours per module [h]": hours,
        "mean voltage drift [mV]": 0.0,
        "max voltage drift [mV]": 0.0,
        "rms tracking error [MW]": 0.0,
    }
    for name, value in expected.items():
        assert row[name] == pytest.approx(value, rel=1e-9, abs=1e-9), name
    assert row["specific energy [kWh/kg]"] == pytest.approx(
        expected["energy drawn [MWh]"] * 1e3 / expected["hydrogen [kg]"], rel=1e-9
    )


def test_an_ageing_hub_reports_its_drift_and_draws_its_energy(tmp_path, fmu_path):
    """The flat reference with ageing: every module runs throughout, so its drift at the end is
    d0 + rho T + A (1 - e^(-T/tau_b)); the current follows the power reference by the curve
    without drift, so the energy drawn is the plain one plus I * integral of d over the run."""
    n, hub_power, hours = 400, 0.8e6, 2.0
    d0, rho, amplitude, tau = 0.01, 2e-3, 0.05, 3600.0  # V, V/h, V, s
    (tmp_path / "flat.csv").write_text(f"time [s],power [kW]\n0,{hub_power / 1e3}\n{hours * 3600},{hub_power / 1e3}\n")
    path = write_study(
        tmp_path,
        f"""horizon = "{hours} h"
[parameters]
nModules = {n}
initialVoltageDrift = {d0}
driftPerRunningHour = {rho}
reversibleDrift = {amplitude}
driftBuildUpTime = {tau}
[series.flat]
file = "flat.csv"
column = "power [kW]"
""",
        fmu_path,
    )
    _, frame = run_study(path, tmp_path / "out", serial=True)
    row = frame.iloc[0]
    assert row["status"] == "done", row["message"]
    t = hours * 3600.0
    drift = d0 + rho * hours + amplitude * (1.0 - math.exp(-t / tau))
    assert row["mean voltage drift [mV]"] == pytest.approx(drift * 1e3, rel=1e-12)
    assert row["max voltage drift [mV]"] == pytest.approx(drift * 1e3, rel=1e-12)
    current = PAPER["gain"] * setpoint_for(hub_power / n)
    drift_integral = (d0 + amplitude) * t + 0.5 * rho / 3600.0 * t * t - amplitude * tau * (1.0 - math.exp(-t / tau))
    energy = (hub_power * t + n * current * drift_integral) / 3.6e9
    assert row["energy drawn [MWh]"] == pytest.approx(energy, rel=1e-9)


def test_a_grid_side_reference_is_drawn_from_the_grid_with_its_losses_and_auxiliaries(tmp_path, fmu_path):
    """The flat reference on the grid side: the hub draws it from the grid; its stack gets what the
    supply's losses and the auxiliaries leave, P + P0 + Vs I + Rs I^2 + P_aux = reference / N."""
    n, hub_power, hours = 400, 0.8e6, 2.0
    aux, p0, vs, rs = 150.0, 30.0, 0.6, 0.015
    (tmp_path / "flat.csv").write_text(f"time [s],power [kW]\n0,{hub_power / 1e3}\n{hours * 3600},{hub_power / 1e3}\n")
    path = write_study(
        tmp_path,
        f"""horizon = "{hours} h"
[parameters]
nModules = {n}
gridSideReference = true
auxiliaryPower = {aux}
supplyNoLoadLoss = {p0}
supplyLossVoltage = {vs}
supplyLossResistance = {rs}
[series.flat]
file = "flat.csv"
column = "power [kW]"
""",
        fmu_path,
    )
    _, frame = run_study(path, tmp_path / "out", serial=True)
    row = frame.iloc[0]
    assert row["status"] == "done", row["message"]
    # Per module: (V0 + Vs) I + (R + Rs) I^2 = reference / N - P0 - P_aux, the positive root.
    a, b, c = PAPER["ohmicResistance"] + rs, PAPER["voltageIntercept"] + vs, -(hub_power / n - p0 - aux)
    current = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    stack = n * (PAPER["voltageIntercept"] + PAPER["ohmicResistance"] * current) * current
    t = hours * 3600.0
    hydrogen = n * PAPER["h2Coefficient"] * current * hours * KG_PER_NL
    assert row["grid energy [MWh]"] == pytest.approx(hub_power * t / 3.6e9, rel=1e-9)
    assert row["energy drawn [MWh]"] == pytest.approx(stack * t / 3.6e9, rel=1e-9)
    assert row["supply losses and auxiliaries [MWh]"] == pytest.approx((hub_power - stack) * t / 3.6e9, rel=1e-8)
    assert row["grid import [MWh]"] == pytest.approx(0.0, abs=1e-9)
    assert row["hydrogen [kg]"] == pytest.approx(hydrogen, rel=1e-9)
    assert row["specific energy, grid side [kWh/kg]"] == pytest.approx(hub_power * hours / 1e3 / hydrogen, rel=1e-9)


def test_a_setpoint_series_drives_the_setpoint_and_has_no_wind_kpis(tmp_path, fmu_path):
    (tmp_path / "sp.csv").write_text("time,setpoint [%]\n2026-01-01T00:00:00Z,80\n2026-01-01T01:00:00Z,80\n")
    path = write_study(
        tmp_path,
        """horizon = "2 h"
[parameters]
nModules = 10
[series.sp]
file = "sp.csv"
time = "time"
column = "setpoint [%]"
""",
        fmu_path,
    )
    _, frame = run_study(path, tmp_path / "out", serial=True)
    row = frame.iloc[0]
    assert row["status"] == "done", row["message"]
    current = PAPER["gain"] * 80.0
    assert row["hydrogen [kg]"] == pytest.approx(10 * PAPER["h2Coefficient"] * current * 2 * KG_PER_NL, rel=1e-9)
    assert row["energy drawn [MWh]"] == pytest.approx(10 * module_power(80.0) * 7200 / 3.6e9, rel=1e-9)
    assert math.isnan(row["wind not absorbed [MWh]"]) and math.isnan(row["rms tracking error [MW]"])


def test_file_series_are_held_or_interpolated_to_the_step():
    times = np.array([0.0, 900.0, 1800.0])
    values = np.array([10.0, 20.0, 40.0])
    definition = {"kind": "file", "interpolation": "hold", "error": None}
    held = reference(definition, 300.0, 2700.0, (times, values))
    assert held.tolist() == [10, 10, 10, 20, 20, 20, 40, 40, 40]
    linear = reference({**definition, "interpolation": "linear"}, 300.0, 2700.0, (times, values))
    assert linear.tolist() == pytest.approx([10, 10 + 10 / 3, 10 + 20 / 3, 20, 20 + 20 / 3, 20 + 40 / 3, 40, 40, 40])
    with pytest.raises(ValueError, match="covers 0.75 h, the horizon is 1 h"):
        reference(definition, 300.0, 3600.0, (times, values))


WIND_STUDY = (
    """horizon = "1 h"
[series.wind]
generator = "wind"
[axes]
seed = [1, 2]
hub_size = [50, 90]
"""
    + MODES
)


@pytest.mark.cluster
def test_the_cluster_gives_the_serial_kpis_bit_for_bit(tmp_path, fmu_path):
    path = write_study(tmp_path, WIND_STUDY, fmu_path)
    _, serial = run_study(path, tmp_path / "serial", serial=True)
    _, one = run_study(path, tmp_path / "one", workers=1)
    _, two = run_study(path, tmp_path / "two", workers=2)
    assert len(serial) == 8 and (serial["status"] == "done").all(), serial["message"].tolist()
    assert serial["modules [1]"].tolist() == [
        round(s / 100 * 64e6 / module_power(PAPER["maxSetpoint"])) for _ in (1, 2) for s in (50, 90) for _ in (1, 2)
    ]
    for frame in (one, two):
        assert frame["scenario"].tolist() == serial["scenario"].tolist()
        np.testing.assert_array_equal(kpi_values(frame), kpi_values(serial))
    assert two["worker"].nunique() == 2, "both worker processes ran scenarios"
    # Conservation per scenario: offered = grid draw + not absorbed − imported (per step, net).
    balance = serial["grid energy [MWh]"] + serial["wind not absorbed [MWh]"] - serial["grid import [MWh]"]
    np.testing.assert_allclose(balance, serial["reference energy [MWh]"], rtol=1e-12)
    # The sequential hub switches modules, the equal one never stops any.
    assert (serial[serial["mode"] == "equal"]["starts per module [1]"] == 0).all()
    assert (serial[serial["mode"] == "sequential"]["starts per module [1]"] > 0).all()


@pytest.mark.cluster
def test_a_refused_parameter_and_a_bad_series_fail_alone(tmp_path, fmu_path):
    (tmp_path / "bad.csv").write_text("time [s],power [MW]\n0,10\n1,ten\n2,10\n")
    (tmp_path / "good.csv").write_text("time [s],power [MW]\n0,1\n600,1\n")
    path = write_study(
        tmp_path,
        """horizon = "10 min"
[parameters]
nModules = 500
[series.good]
file = "good.csv"
column = "power [MW]"
[series.bad]
file = "bad.csv"
column = "power [MW]"
[axes]
series = ["good", "bad"]
hysteresis = [-1, 5]
""",
        fmu_path,
    )
    done = subprocess.run(
        AEM_STUDY + [str(path), "--out", str(tmp_path / "out"), "--workers", "2", "--no-plots"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 1, done.stderr
    frame = pd.read_parquet(tmp_path / "out" / "kpis.parquet")
    status = dict(zip(zip(frame["series"], frame["hysteresis [%]"]), zip(frame["status"], frame["message"])))
    assert status[("good", 5.0)][0] == "done"
    assert status[("good", -1.0)][0] == "failed"
    assert "hysteresis = -1 is invalid" in status[("good", -1.0)][1], "the FMU's own message"
    for h in (-1.0, 5.0):
        assert status[("bad", h)][0] == "failed" and "row 2: the value is not a number" in status[("bad", h)][1]
    summary = (tmp_path / "out" / "summary.txt").read_text()
    assert "hysteresis = -1 is invalid" in summary and done.stdout.startswith(summary.splitlines()[0])


WIND = '[series.w]\ngenerator = "wind"\n'


def assert_one_line(err, *said):
    """stderr is one line, no traceback, and says each of `said`."""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for words in said:
        assert words in err, (words, err)


def test_study_file_mistakes_stop_before_anything_runs(tmp_path, fmu_path, capsys):
    """Each mistake: status 2, one line naming the file, the table and key, and the nearest
    allowed name; no output folder made. A file series' header is checked with the file: its
    columns named by the keys, the unit of its value column, its rating."""
    (tmp_path / "flat.csv").write_text("time [s],power [MW]\n0,1\n600,1\n")
    (tmp_path / "stamped.csv").write_text("timestamp,power [MW]\n0,1\n600,1\n")
    (tmp_path / "zero.csv").write_text("time [s],power [MW]\n0,0\n600,0\n")
    (tmp_path / "sp.csv").write_text("time [s],setpoint [%]\n0,80\n600,80\n")
    (tmp_path / "nounit.csv").write_text("time [s],power\n0,1\n600,1\n")
    flat = '[series.f]\nfile = "flat.csv"\ncolumn = "power [MW]"\n'
    setpoint = '[series.s]\nfile = "sp.csv"\ncolumn = "setpoint [%]"\n'
    for body, said in [
        (
            '[series.f]\nfile = "flat.csv"\ncolumn = "power [kW]"\n',
            "[series.f] column: no column 'power [kW]' in "
            f"{tmp_path / 'flat.csv'} (did you mean 'power [MW]'?); its columns: 'time [s]', 'power [MW]'",
        ),
        (
            '[series.f]\nfile = "stamped.csv"\ncolumn = "power [MW]"\n',
            "[series.f] time: no column 'time [s]' (the default: give time = \"NAME\") in",
        ),
        (
            '[series.f]\nfile = "stamped.csv"\ntime = "timestamps"\ncolumn = "power [MW]"\n',
            "[series.f] time: no column 'timestamps' in",
        ),
        ('[series.f]\nfile = "nounit.csv"\ncolumn = "power"\n', "[series.f] column: 'power' names no unit"),
        (flat + "rating = 0\n", "[series.f] rating: 0 is not a positive power"),
        (flat + "rating = inf\n", "[series.f] rating: inf is not a positive power"),
        (flat + 'rating = "64 MWh"\n', "[series.f] rating: '64 MWh' is not a number with a unit of W, kW, MW"),
        (setpoint + 'rating = "1 MW"\n', "[series.s] rating: 'setpoint [%]' is a setpoint series (%)"),
        (setpoint + "[axes]\nhub_size = [50]\n", "[axes] hub_size: series 's' is a setpoint series (%)"),
        (
            '[series.z]\nfile = "zero.csv"\ncolumn = "power [MW]"\n[axes]\nhub_size = [50]\n',
            "[axes] hub_size: series 'z' has no positive value to size hubs against: give rating",
        ),
        (WIND + "[axes]\nhysterisis = [1]\n", "[axes]: unknown axis 'hysterisis' (did you mean 'hysteresis'?)"),
        (WIND + "[axes]\nhub_sise = [40]\n", "[axes]: unknown axis 'hub_sise' (did you mean 'hub_size'?)"),
        (
            WIND + '[axes]\ndispatch = ["equally"]\n',
            "one of equal, sequential, rotation, target (did you mean 'equal'?)",
        ),
        (WIND + "[parameters]\nnModules = 2.5\n", "[parameters] nModules = 2.5 is not an Integer"),
        (WIND + "[parameters]\nhysterisis = 2\n", "no parameter 'hysterisis' (did you mean 'hysteresis'?)"),
        (WIND + "[parameters]\npowerInput = true\n", "set by aem-study"),
        (WIND + "[parameters]\nhub_size = 80\n", "hub_size is an axis, not an FMU parameter"),
        ("[axes]\nseed = [1]\n", "no [series.NAME] table"),
        (WIND + "climate = { mean_sped = 9 }\n", "unknown field 'mean_sped' (did you mean 'mean_speed'?)"),
        (
            '[series.f]\nfile = "x.csv"\ncolumn = "p [MW]"\ninterpolate = "linear"\n',
            "[series.f]: unknown key 'interpolate' (did you mean 'interpolation'?)",
        ),
        ('[series.f]\nfile = "x.csv"\ncolumn = "p [MW]"\n', "[series.f] file: no file"),
        (WIND + "[axis]\nseed = [1]\n", "unknown table [axis] (did you mean 'axes'?)"),
        (WIND + '[axes]\nseed = [1, "two"]\n', "[axes] seed: 'two' is not a seed"),
        (WIND + "[axes]\nhub_size = [40, 0]\n", "[axes] hub_size: 0 is not a hub size"),
        (WIND + '[axes]\nstep = ["1 s", "0 s"]\n', "[axes] step: '0 s' is not a positive duration"),
        (WIND + "[axes]\nhub_size = 40\n", "[axes] hub_size: give a non-empty list"),
        (WIND + '[axes.mode]\nequal = "equal"\n', "[axes.mode] equal must be a table"),
        (WIND + "[axes]\nseed = [1,\n", "not valid TOML"),
    ]:
        path = write_study(tmp_path, body, fmu_path)
        assert cli.main([str(path), "--serial", "--out", str(tmp_path / "out")]) == 2, body
        err = capsys.readouterr().err
        assert_one_line(err, str(path), said)
        assert not (tmp_path / "out").exists(), body
    assert cli.main([str(tmp_path / "missing.toml"), "--serial"]) == 2
    assert_one_line(capsys.readouterr().err, "missing.toml: no such study file")


def test_a_misspelled_axis_names_the_valid_axes_and_the_nearest(tmp_path, fmu_path):
    """The installed command, as a user meets it: one line on stderr, status 2, the valid axes
    (the study's own and the FMU's parameters), the nearest one; nothing on stdout."""
    path = write_study(tmp_path, WIND + "[axes]\nseed = [1]\nhub_sise = [40, 60]\n", fmu_path)
    done = subprocess.run(
        AEM_STUDY + [str(path), "--serial", "--out", str(tmp_path / "out")], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2 and done.stdout == "", done
    assert_one_line(
        done.stderr,
        "aem-study: error: ",
        str(path),
        "'hub_sise'",
        "did you mean 'hub_size'?",
        "valid axes: series, seed, hub_size, step, horizon",
        "hysteresis",
        "dispatch",
        "nModules",
    )
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "arguments, said",
    [
        (["--workers", "0"], "--workers: must be a positive integer, not 0"),
        (["--workers", "-1"], "--workers: must be a positive integer, not -1"),
        (["--workers", "two"], "--workers: 'two' is not an integer"),
        (["--workers", "2", "--serial"], "not allowed with argument"),
        (["--serail"], "unknown option --serail (did you mean '--serial'?)"),
        (["--runner", "no-such-aem-run"], "--runner: no file no-such-aem-run"),
        (["--runner", str(Path(__file__)), "--serial"], "is not a program"),  # before anything runs
        (["--example", "hub_sizing"], "--example writes a study file: give no STUDY.toml with it"),
    ],
)
def test_bad_arguments_are_one_line_and_status_2(tmp_path, fmu_path, capsys, arguments, said):
    path = write_study(tmp_path, WIND, fmu_path)
    assert cli.main([str(path), "--out", str(tmp_path / "out"), *arguments]) == 2
    assert_one_line(capsys.readouterr().err, said)
    assert not (tmp_path / "out").exists()


def test_out_is_a_folder(tmp_path, fmu_path, capsys):
    path = write_study(tmp_path, WIND, fmu_path)
    (tmp_path / "file").write_text("")
    assert cli.main([str(path), "--serial", "--out", str(tmp_path / "file")]) == 2
    assert_one_line(capsys.readouterr().err, "--out:", "is a file; --out names a folder")


def test_a_failure_of_the_run_is_one_line_and_status_1(tmp_path, fmu_path, capsys, monkeypatch):
    """The run itself failing (a cluster gone, a disk full): one line, status 1; the traceback
    with --debug."""

    def broken(*args, **kwargs):
        raise RuntimeError("the scheduler\nwent away")

    monkeypatch.setattr(engine, "run", broken)
    path = write_study(tmp_path, WIND, fmu_path)
    assert cli.main([str(path), "--serial", "--out", str(tmp_path / "out")]) == 1
    assert_one_line(capsys.readouterr().err, "error: the scheduler went away (--debug shows the traceback)")
    with pytest.raises(RuntimeError, match="went away"):
        cli.main([str(path), "--serial", "--out", str(tmp_path / "out"), "--debug"])


FLAT = """horizon = "10 min"
[parameters]
nModules = 500
[series.flat]
file = "flat.csv"
column = "power [MW]"
[axes]
hysteresis = [2, 5]
"""


def test_quiet_prints_nothing_but_writes_the_report(tmp_path, fmu_path, capsys):
    """--quiet: no summary, no progress; the files all the same. Without it (stdout not a
    terminal here): the summary on stdout, a line per finished scenario on stderr, no bar."""
    (tmp_path / "flat.csv").write_text("time [s],power [MW]\n0,1\n600,1\n")
    path = write_study(tmp_path, FLAT, fmu_path)
    arguments = [str(path), "--serial", "--runner", str(RUNNER), "--no-plots"]
    assert cli.main(arguments + ["--out", str(tmp_path / "quiet"), "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert out == "" and "[finished" not in err, (out, err)
    assert (tmp_path / "quiet" / "summary.txt").is_file()
    assert cli.main(arguments + ["--out", str(tmp_path / "loud")]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("Study: test\n") and "largest hydrogen [kg]" in out
    finished = [line for line in err.splitlines() if line.startswith("[finished")]
    assert len(finished) == 2 and "\r" not in err, err


class Terminal:
    """A stream that says it is a terminal (tqdm draws on it)."""

    def __init__(self, tty):
        self.tty, self.text = tty, []

    def isatty(self):
        return self.tty

    def write(self, text):
        self.text.append(text)

    def flush(self):
        pass


@pytest.mark.parametrize(
    "stdout_tty, stream_tty, quiet, kind",
    [
        (True, True, False, "bar"),
        (False, True, False, "lines"),  # stdout is a log or a pipe: no bar
        (True, False, False, "lines"),  # stderr to a file: no bar
        (True, True, True, "nothing"),
        (False, False, True, "nothing"),
    ],
)
def test_progress_follows_quiet_and_the_terminal(monkeypatch, stdout_tty, stream_tty, quiet, kind):
    monkeypatch.setattr(sys, "stdout", Terminal(stdout_tty))
    stream = Terminal(stream_tty)
    shown = progress.Progress(2, 0, stream=stream, quiet=quiet)
    assert (shown.bar is not None) == (kind == "bar")
    for _ in range(2):
        shown.finished({"status": "done"}, 0, {"seed": 1})
    shown.close()
    lines = [t for t in stream.text if t.startswith("[finished")]
    assert len(lines) == (2 if kind == "lines" else 0)
    assert (stream.text == []) == (kind == "nothing")


GATED_STUDY = """horizon = "3 h"
[parameters]
nModules = 25000
dispatch = "sequential"
belowMinimum = "standby"
[series.wind]
generator = "wind"
[axes]
seed = [1, 2, 3, 4, 5, 6]
"""

GATED_RUNNER = """#!/bin/sh
# aem-run behind a gate the test controls: each run waits for a token in GATE (taken with an
# atomic rename, so one token lets exactly one run through) or for GATE/open; it ends as a
# scenario that fails at GATE/close (as running scenarios end while a stopped study closes its
# cluster) or when its worker has gone (so that nothing outlives a study).
while :; do
  [ -e "{gate}/close" ] && exit 3
  [ -e "{gate}/open" ] && exec "{runner}" "$@"
  for token in "{gate}"/token-*; do
    mv "$token" "{gate}/taken-$$" 2>/dev/null && exec "{runner}" "$@"
  done
  kill -0 $PPID 2>/dev/null || exit 3
  sleep 0.05
done
"""


class Gate:
    """Scenarios of aem-study run only as far as the test lets them: `--runner` is a gated
    aem-run (its name keeps "aem-run"), so the test, not the machine's speed, decides how many
    scenarios finish before it stops the study or kills a worker."""

    def __init__(self, folder):
        self.folder = folder / "gate"
        self.folder.mkdir()
        self.runner = folder / "gated-aem-run"
        self.runner.write_text(GATED_RUNNER.format(gate=self.folder, runner=RUNNER))
        self.runner.chmod(0o755)
        self.issued = 0

    def let_through(self, n):
        for _ in range(n):
            self.issued += 1  # a name of its own for each token
            (self.folder / f"token-{self.issued}").write_text("")

    def open(self):
        (self.folder / "open").write_text("")

    def close(self):
        (self.folder / "close").write_text("")

    def reopen(self):
        (self.folder / "close").unlink()
        self.open()


#: Runs the command of its arguments with SIGINT at its default disposition. A test's SIGINT
#: stands for Ctrl-C; but a suite started in the background (`cmd &` in a script) inherits
#: SIGINT ignored, an ignored signal stays ignored across exec, and Python then installs no
#: KeyboardInterrupt handler: the command would never see the signal.
WITH_SIGINT = [
    sys.executable,
    "-c",
    "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); os.execv(sys.argv[1], sys.argv[1:])",
]


def start(argv):
    """aem-study started in a process group of its own (its Dask workers and their aem-run
    with it), so that `end_group` leaves nothing behind when a test fails, and with SIGINT at
    its default, so that the test's SIGINT is Ctrl-C's."""
    return subprocess.Popen(
        WITH_SIGINT + argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )


def end_group(process):
    """Kills what is left of the process group of `process` (nothing when the test passed)."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def stored(out):
    folder = out / "scenarios"
    return {p.name: p.stat().st_mtime_ns for p in folder.glob("*.json")} if folder.exists() else {}


def wait_for(condition, what, timeout=120):
    """Polls `condition` until it gives a true value, which it returns."""
    end = time.monotonic() + timeout
    while not (value := condition()):
        assert time.monotonic() < end, f"timed out waiting for {what}"
        time.sleep(0.05)
    return value


def cmdline(pid):
    """The command line of process `pid`, or "" if it has ended meanwhile."""
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().decode(errors="replace")
    except OSError:
        return ""


def children(pid):
    """Every descendant process id of `pid` (from /proc)."""
    out, todo = [], [pid]
    while todo:
        parent = todo.pop()
        try:
            tasks = os.listdir(f"/proc/{parent}/task")
        except OSError:  # ended meanwhile
            continue
        for task in tasks:
            try:
                with open(f"/proc/{parent}/task/{task}/children") as f:
                    kids = f.read().split()
            except OSError:
                continue
            out += [int(k) for k in kids]
            todo += [int(k) for k in kids]
    return out


@pytest.mark.cluster
def test_a_stopped_study_resumes_and_runs_nothing_twice(tmp_path, fmu_path):
    path = write_study(tmp_path, GATED_STUDY, fmu_path)
    out, gate = tmp_path / "out", Gate(tmp_path)
    study = AEM_STUDY + [str(path), "--out", str(out), "--workers", "2", "--no-plots", "--runner", str(gate.runner)]
    first = start(study)
    try:
        gate.let_through(2)
        wait_for(lambda: len(stored(out)) == 2, "two stored scenarios")
        first.send_signal(signal.SIGINT)  # two more wait at the gate, two are queued
        gate.close()  # the two waiting end, as running scenarios do, and the cluster closes
        _, err = first.communicate(timeout=120)
    finally:
        end_group(first)
    assert first.returncode == 130 and "run again to resume" in err, err
    before = stored(out)
    assert len(before) == 2
    gate.reopen()
    second = subprocess.run(study, capture_output=True, text=True, timeout=300)
    assert second.returncode == 0, second.stderr
    ran = [line for line in second.stderr.splitlines() if line.startswith("[finished")]
    assert len(ran) == 4, "only the missing scenarios ran"
    after = stored(out)
    assert len(after) == 6 and all(after[name] == mtime for name, mtime in before.items())
    third = subprocess.run(
        AEM_STUDY + [str(path), "--out", str(out), "--serial", "--no-plots"], capture_output=True, text=True, timeout=60
    )
    assert third.returncode == 0 and "[finished" not in third.stderr and stored(out) == after


def kill_a_worker_mid_scenario(study, gate, out):
    """Lets one scenario finish, kills a worker process whose gated aem-run waits at the gate,
    opens the gate; the study's (stdout, stderr)."""
    gate.let_through(1)
    wait_for(lambda: len(stored(out)) == 1, "a stored scenario")

    def waiting_worker():
        """A worker process whose gated aem-run waits at the gate now, or None (a process that
        ends while it is looked at is simply not found)."""
        for worker in children(study.pid):
            if "aem-run" not in cmdline(worker) and any("aem-run" in cmdline(c) for c in children(worker)):
                return worker
        return None

    worker = wait_for(waiting_worker, "a worker running aem-run")
    os.kill(worker, signal.SIGKILL)  # the worker process running a scenario, mid-scenario
    gate.open()
    return study.communicate(timeout=300)


@pytest.mark.cluster
def test_a_killed_worker_loses_nothing(tmp_path, fmu_path):
    path = write_study(tmp_path, GATED_STUDY, fmu_path)
    out, gate = tmp_path / "out", Gate(tmp_path)
    study = start(
        AEM_STUDY + [str(path), "--out", str(out), "--workers", "2", "--no-plots", "--runner", str(gate.runner)]
    )
    try:
        _, stderr = kill_a_worker_mid_scenario(study, gate, out)
    finally:
        end_group(study)
    assert study.returncode == 0, stderr
    records = [json.loads(p.read_text()) for p in (out / "scenarios").glob("*.json")]
    assert len(records) == 6 and {r["status"] for r in records} == {"done"}
    first = pd.read_parquet(out / "kpis.parquet")
    again = subprocess.run(
        AEM_STUDY + [str(path), "--out", str(out), "--workers", "2", "--no-plots"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert again.returncode == 0 and "[finished" not in again.stderr
    second = pd.read_parquet(out / "kpis.parquet")
    np.testing.assert_array_equal(kpi_values(first), kpi_values(second))
    assert len(second) == 6


SMALL_WIND = (
    """horizon = "20 min"
[parameters]
nModules = 2000
[series.wind]
generator = "wind"
[axes]
seed = [3, 4]
"""
    + MODES
)


def test_the_package_zip_runs_a_scenario_without_this_repository(tmp_path, fmu_path):
    """What a worker of an existing cluster gets (the uploaded zip, the bundle) is all it needs:
    a fresh interpreter that cannot see this checkout imports the study package from the zip
    and gives the serial KPIs."""
    study = Study(write_study(tmp_path, SMALL_WIND, fmu_path))
    scenario = study.scenarios()[1]
    payload = engine.bundle(study, RUNNER)
    expected = run_scenario(scenario.key, scenario.definition, payload)
    assert expected["status"] == "done", expected["message"]
    archive = engine._package_zip()
    try:
        job = tmp_path / "job.pickle"
        job.write_bytes(pickle.dumps((scenario.key, scenario.definition, payload)))
        code = f"""
import json, pickle
import aem_electrolyser.study.worker as worker, aem_electrolyser.wind.farm as farm
assert worker.__file__.startswith({archive!r}) and farm.__file__.startswith({archive!r}), worker.__file__
print(json.dumps(worker.run_scenario(*pickle.loads(open({str(job)!r}, "rb").read()))))
"""
        # -S: no site processing, so the editable install's .pth is not read; the dependencies come
        # from site-packages and the package only from the zip, as on a worker that has no install.
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([archive, sysconfig.get_paths()["purelib"]])}
        done = subprocess.run(
            [sys.executable, "-S", "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120, env=env
        )
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout)["kpis"] == expected["kpis"]
    finally:
        os.unlink(archive)


@pytest.mark.cluster
def test_an_existing_cluster_runs_the_study_as_the_serial_run(tmp_path, fmu_path):
    """`--scheduler`: a `dask scheduler` and a `dask worker` of two processes on the loopback."""
    path = write_study(tmp_path, SMALL_WIND, fmu_path)
    _, serial = run_study(path, tmp_path / "serial", serial=True)
    dask = str(BIN / "dask")
    address_file = tmp_path / "scheduler.json"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    scheduler = subprocess.Popen(
        WITH_SIGINT
        + [
            dask,
            "scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            "0",
            "--no-dashboard",
            "--scheduler-file",
            str(address_file),
        ],
        **quiet,
    )
    worker = None
    try:
        wait_for(address_file.is_file, "the scheduler's address", timeout=60)
        worker = subprocess.Popen(
            WITH_SIGINT
            + [
                dask,
                "worker",
                "--scheduler-file",
                str(address_file),
                "--nworkers",
                "2",
                "--nthreads",
                "1",
                "--no-dashboard",
            ],
            **quiet,
        )
        address = json.loads(address_file.read_text())["address"]
        done = subprocess.run(
            AEM_STUDY + [str(path), "--out", str(tmp_path / "cluster"), "--scheduler", address, "--no-plots"],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
    cluster = pd.read_parquet(tmp_path / "cluster" / "kpis.parquet")
    assert cluster["scenario"].tolist() == serial["scenario"].tolist()
    np.testing.assert_array_equal(kpi_values(cluster), kpi_values(serial))


def test_module_parameter_files_are_an_axis_shipped_with_the_scenario(tmp_path, fmu_path):
    """A moduleParameterFile axis: each file goes to the workers by its hash (no shared file
    system); the modules take its gains round robin: m = Σ_k c K_k u t."""
    for name, gains in (("two.json", [0.50, 0.56]), ("one.json", [0.50])):
        modules = [
            {"module": f"M{k}", "parameters": {"gain": {"value": g, "unit": "A/%", "source": "identified"}}}
            for k, g in enumerate(gains)
        ]
        (tmp_path / name).write_text(json.dumps({"generator": "test", "modules": modules}))
    (tmp_path / "sp.csv").write_text("time [s],setpoint [%]\n0,80\n3600,80\n")
    path = write_study(
        tmp_path,
        """horizon = "1 h"
[parameters]
nModules = 4
[series.sp]
file = "sp.csv"
column = "setpoint [%]"
[axes]
moduleParameterFile = ["two.json", "one.json"]
""",
        fmu_path,
    )
    study, frame = run_study(path, tmp_path / "out", serial=True)
    assert frame["moduleParameterFile"].tolist() == ["two.json", "one.json"]
    assert study.scenarios()[0].definition["parameters"]["moduleParameterFile"].startswith("file:sha256:")
    c = PAPER["h2Coefficient"]
    for (_, row), gains in zip(frame.iterrows(), ([0.50, 0.56, 0.50, 0.56], [0.50] * 4)):
        assert row["status"] == "done", row["message"]
        assert row["hydrogen [kg]"] == pytest.approx(sum(c * k * 80.0 for k in gains) * KG_PER_NL, rel=1e-9)


# --- Ctrl-C, --version and --help without the extra, the example studies, the series' checks ------


@pytest.mark.cluster
def test_ctrl_c_in_the_terminal_stops_the_cluster_at_once_and_the_study_resumes(tmp_path, fmu_path):
    """Ctrl-C in a terminal signals every process of the group: aem-study, its Dask workers and
    their aem-run. One line and status 130, soon, no worker's traceback; what finished is stored,
    what was running is not (it was stopped, it did not fail), and a rerun runs only that."""
    path = write_study(tmp_path, GATED_STUDY, fmu_path)
    out, gate = tmp_path / "out", Gate(tmp_path)
    study = AEM_STUDY + [str(path), "--out", str(out), "--workers", "2", "--no-plots", "--runner", str(gate.runner)]
    first = start(study)
    try:
        gate.let_through(1)
        wait_for(lambda: len(stored(out)) == 1, "a stored scenario")
        # Both workers on their next scenario: their gated aem-run wait at the gate.
        wait_for(lambda: sum("aem-run" in cmdline(c) for c in children(first.pid)) >= 2, "two running scenarios")
        sent = time.monotonic()
        os.killpg(first.pid, signal.SIGINT)  # as the terminal does
        _, err = first.communicate(timeout=120)
        took = time.monotonic() - sent
    finally:
        end_group(first)
    said = [line for line in err.splitlines() if line.strip() and not line.startswith("[finished")]
    assert first.returncode == 130 and "Traceback" not in err, err
    assert len(said) == 1 and "stopped; finished scenarios are kept" in said[0] and "run again" in said[0], err
    assert took < 15, f"{took:.1f} s from Ctrl-C to the end"
    before = stored(out)
    assert len(before) == 1, "the stopped scenarios are not stored as failed"
    gate.open()
    second = subprocess.run(study, capture_output=True, text=True, timeout=300)
    assert second.returncode == 0, second.stderr
    assert len([line for line in second.stderr.splitlines() if line.startswith("[finished")]) == 5
    after = stored(out)
    assert len(after) == 6 and all(after[name] == mtime for name, mtime in before.items())


#: Runs aem-study's entry point as if the [study] extra were not installed: its packages
#: neither import nor are found (extras.missing looks them up as a core-only install would).
WITHOUT_STUDY_EXTRA = """
import runpy, sys
BLOCKED = {"dask", "distributed", "pandas", "pyarrow", "matplotlib"}
class NotInstalled:
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None
sys.meta_path.insert(0, NotInstalled())
how, sys.argv = sys.argv[1], sys.argv[1:]
if how == "entry point":
    sys.argv[0] = "aem-study"
    from aem_electrolyser.commands import study
    study()
else:
    runpy.run_module("aem_electrolyser.study", run_name="__main__", alter_sys=True)
"""


@pytest.mark.parametrize("how", ["entry point", "module"])
def test_help_version_and_examples_answer_without_the_study_extra(tmp_path, fmu_path, how):
    """--help, --version and --example need nothing of the [study] extra (the parser imports
    none of it); running a study names the extra in one line."""
    from aem_electrolyser import __version__

    def run(*arguments):
        return subprocess.run(
            [sys.executable, "-c", WITHOUT_STUDY_EXTRA, how, *arguments],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=120,
        )

    shown = run("--help")
    assert shown.returncode == 0 and "--example" in shown.stdout and "--workers" in shown.stdout, shown
    version = run("--version")
    assert version.returncode == 0 and version.stdout == f"aem-study {__version__}\n", version
    if how == "module":  # the entry point's extra check is commands.py's
        listed = run("--example")
        assert listed.returncode == 0 and listed.stdout.startswith("hub_sizing "), listed
    refused = run(str(write_study(tmp_path, WIND, fmu_path)))
    assert refused.returncode == 1 and "Traceback" not in refused.stderr, refused
    assert_one_line(refused.stderr, "needs the [study] extra", "pip install 'aem-electrolyser[study]'")


def test_an_example_study_is_written_and_runs(tmp_path, fmu_path, monkeypatch, capsys):
    """--example lists the examples shipped in the package; --example NAME writes one (to
    NAME.toml here, or to --out), never over an existing file; the file written is a study
    that reads and, at a short horizon, runs. The checkout keeps no second copy of it."""
    from conftest import ROOT

    monkeypatch.setenv("AEM_FMU", str(fmu_path))
    monkeypatch.chdir(tmp_path)
    assert cli.main(["--example"]) == 0
    listed = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in listed] == ["hub_sizing"] and "64 MW" in listed[0]
    assert cli.main(["--example", "hub_sizing"]) == 0
    written = tmp_path / "hub_sizing.toml"
    assert written.read_text() == (Path(cli.__file__).parent / "examples" / "hub_sizing.toml").read_text()
    assert f"wrote {written.name}" in capsys.readouterr().out
    assert cli.main(["--example", "hub_sizing"]) == 2, "never over an existing file"
    assert_one_line(capsys.readouterr().err, "hub_sizing.toml exists")
    (tmp_path / "mine").mkdir()
    assert cli.main(["--example", "hub_sizing", "--out", "mine"]) == 0
    assert (tmp_path / "mine" / "hub_sizing.toml").read_text() == written.read_text()
    assert cli.main(["--example", "hub_sizng"]) == 2
    assert_one_line(capsys.readouterr().err, "--example: no example 'hub_sizng' (did you mean 'hub_sizing'?)")

    study = Study(written)
    assert len(study.scenarios()) == 36 and study.horizon == 365 * 86400.0
    assert study.axis_columns == ["series", "seed", "hub size [%]", "dispatch"]
    short = tmp_path / "short.toml"
    short.write_text(
        written.read_text().replace('horizon = "365 d"', 'horizon = "1 min"').replace("seed = [1, 2, 3]", "seed = [1]")
    )
    _, frame = run_study(short, tmp_path / "out", serial=True)
    assert len(frame) == 12 and (frame["status"] == "done").all(), frame["message"].tolist()
    assert not (ROOT / "examples" / "hub_sizing.toml").exists(), "one copy: the package's"


def test_the_closing_line_names_the_files_where_they_are(tmp_path, fmu_path, capsys):
    (tmp_path / "flat.csv").write_text("time [s],power [MW]\n0,1\n600,1\n")
    path = write_study(
        tmp_path, FLAT.replace("nModules = 500\n", "").replace("hysteresis = [2, 5]", "nModules = [500, 600]"), fmu_path
    )
    out = tmp_path / "out"
    assert cli.main([str(path), "--serial", "--runner", str(RUNNER), "--out", str(out)]) == 0
    closing = capsys.readouterr().out.splitlines()[-1]
    assert closing.startswith(f"wrote {out}/: "), closing
    names = closing.removeprefix(f"wrote {out}/: ").split(", ")
    assert any(name.startswith("plots/") and name.endswith(".png") for name in names), closing
    assert all((out / name).is_file() for name in names), closing


def test_aem_fmu_pointing_nowhere_is_named_as_the_cause(tmp_path, fmu_path, monkeypatch, capsys):
    """A study without fmu = ... takes the FMU of the environment variable AEM_FMU if set: an
    error is AEM_FMU's, not the study file's."""
    (tmp_path / "study.toml").write_text('[study]\ntitle = "test"\n' + WIND)
    (tmp_path / "text.fmu").write_text("not an FMU\n")
    for value, said in ((tmp_path / "no" / "such.fmu", "no such FMU"), (tmp_path / "text.fmu", "is not an FMU")):
        monkeypatch.setenv("AEM_FMU", str(value))
        assert cli.main([str(tmp_path / "study.toml"), "--serial", "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err
        assert_one_line(err, f"AEM_FMU: {value}", said)
        assert "[study] fmu" not in err and "--fmu" not in err, err


def test_a_bad_series_says_so_whatever_the_horizon(tmp_path, fmu_path):
    """A series whose rows are bad fails its scenarios with its own words, also when the
    horizon is its span (the default), which a bad series does not have."""
    (tmp_path / "bad.csv").write_text("time [s],power [MW]\n0,10\n1,ten\n2,10\n")
    path = write_study(tmp_path, '[series.bad]\nfile = "bad.csv"\ncolumn = "power [MW]"\n', fmu_path)
    _, frame = run_study(path, tmp_path / "out", serial=True)
    assert frame["status"].tolist() == ["failed"]
    assert "row 2: the value is not a number" in frame["message"].iloc[0], frame["message"].iloc[0]


def test_the_file_series_keys_are_documented():
    """Every key of a file series (rating too) is in the study file format of docs/studies.md."""
    from conftest import ROOT

    from aem_electrolyser.study.definition import FILE_SERIES_KEYS

    text = (ROOT / "docs" / "studies.md").read_text()
    block = text[text.index("[series.site]") :]
    block = block[: block.index("```")]
    for key in FILE_SERIES_KEYS:
        assert f"\n{key} = " in block, key


def test_a_runner_killed_by_a_signal_leaves_no_record(tmp_path, fmu_path):
    """aem-run ended by a signal (Ctrl-C, its worker closing, the OOM killer) did not fail its
    scenario: no record, so a rerun runs it (on Dask the client counts it lost)."""
    (tmp_path / "flat.csv").write_text("time [s],power [MW]\n0,1\n600,1\n")
    killed = tmp_path / "killed-aem-run"
    killed.write_text("#!/bin/sh\nkill -KILL $$\n")
    killed.chmod(0o755)
    study = Study(write_study(tmp_path, FLAT, fmu_path))
    with pytest.raises(RunnerKilled, match="killed by signal 9"):
        engine.run(study, tmp_path / "out", serial=True, runner=killed, quiet=True)
    assert stored(tmp_path / "out") == {}
