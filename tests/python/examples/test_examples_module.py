"""The issue-5 examples, run as a user would, with short horizons, checked against closed forms.

aem_electrolyser.examples.step_responses: final currents K*u, the 90 % and 98 % times of every step against
the two-exponential response of Table I (with the ramp limit for positive steps), no overshoot.
aem_electrolyser.examples.validation_day (a two-day campaign): identified parameters near the generator's
truth, an FMU that carries them, and a held-out current RMSE near the generator's noise that
agrees with `aem-identify validate`.
"""

import csv
import hashlib
import math
import re
import subprocess
import sys

import numpy as np
import pytest
from fmpy import read_model_description

from conftest import FMU_PATH, PAPER, REBUILDS_THE_LIBRARY, ROOT, unlimited_step_response

NOISE = 0.15  # current noise of the synthetic generator [A]
TRUTH = dict(gain=0.512, rampUpLimit=0.18, voltageIntercept=36.4, ohmicResistance=0.1412)  # CampaignSpec::test_truth


def run_example(name, *args):
    result = subprocess.run(
        [sys.executable, "-m", f"aem_electrolyser.examples.{name}", *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def closed_form_time(u0, u1, fraction):
    """Time [s] the Table I model takes to cover `fraction` of the step u0 -> u1 [%] (bisection)."""
    k, r = PAPER["gain"], PAPER["rampUpLimit"]

    def current(t):
        i = unlimited_step_response(u0, u1, t)
        return min(k * u0 + r * t, i) if u1 > u0 else i  # a rising step: ramp until G(s) is below it

    def progress(t):
        return (current(t) - k * u0) / (k * (u1 - u0))

    lo, hi = 0.0, 2000.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if progress(mid) < fraction else (lo, mid)
    return 0.5 * (lo + hi)


def test_the_quick_start_demo_warns_only_of_its_excursion(fmu_path, tmp_path):
    """The demo (scripts/demo.sh runs it) gives fmpy every input, so its only message is the
    FMU's own warning when the schedule leaves the operating window (40 % at 2100 s); the run
    ends at 100 % in steady state, current K*100."""
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "aem_electrolyser.examples.step_schedule",
            "--fmu",
            str(fmu_path),
            "--out",
            str(tmp_path / "demo"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    messages = result.stderr.splitlines()
    assert messages == [
        "[WARNING] setpoint = 40 % is outside the operating window [60, 100] %; "
        "the module runs at 60 % until it returns"
    ], messages
    last = read_rows(tmp_path / "demo" / "step_schedule.csv")[-1]
    assert float(last["current [A]"]) == pytest.approx(PAPER["gain"] * 100.0, rel=1e-3)


def test_step_responses_match_the_closed_form(fmu_path, tmp_path):
    out = run_example("step_responses", "--fmu", fmu_path, "--out", tmp_path, "--duration", 1500, "--dt", 0.5)
    rows = read_rows(tmp_path / "step_responses_table.csv")
    assert [(float(r["from [%]"]), float(r["to [%]"])) for r in rows] == [
        (100, 100 - s) for s in (5, 10, 20, 30, 40)
    ] + [(60, 60 + s) for s in (5, 10, 20, 30, 40)]
    for r in rows:
        u0, u1 = float(r["from [%]"]), float(r["to [%]"])
        assert 60 <= min(u0, u1) and max(u0, u1) <= 100
        # 1500 s after the step the slow mode has decayed to ~1e-7 of the step.
        assert float(r["I(end) [A]"]) == pytest.approx(PAPER["gain"] * u1, abs=1e-4), r
        assert float(r["t90 [s]"]) == pytest.approx(closed_form_time(u0, u1, 0.9), abs=0.01), r
        assert float(r["t98 [s]"]) == pytest.approx(closed_form_time(u0, u1, 0.98), abs=0.01), r
        assert float(r["overshoot [% of step]"]) < 1e-6, r
    # Negative steps: t90 = 55.6 s whatever the size (linear model); the 40 % rise is ramp-limited.
    assert float(rows[4]["t90 [s]"]) == pytest.approx(55.6, abs=0.05)
    assert float(rows[9]["t90 [s]"]) == pytest.approx(0.9 * 0.534 * 40 / 0.22, abs=0.01)
    assert "t90" in out and (tmp_path / "step_responses.png").read_bytes()[:4] == b"\x89PNG"
    header = read_rows(tmp_path / "step_responses.csv")[0].keys()
    assert len(header) == 11


@pytest.mark.slow
@REBUILDS_THE_LIBRARY
def test_validation_day_recovers_the_truth_through_the_fmu(tmp_path):
    shipped = hashlib.sha256(FMU_PATH.read_bytes()).hexdigest() if FMU_PATH is not None else None
    out = run_example("validation_day", "--out", tmp_path, "--days", 2, "--hours", 4, "--seed", 11)

    params = {r["parameter"]: r for r in read_rows(tmp_path / "validation_parameters.csv")}
    for name, true in TRUTH.items():
        assert float(params[name]["true"]) == true, name
    assert float(params["gain"]["identified"]) == pytest.approx(TRUTH["gain"], rel=0.01)
    assert float(params["rampUpLimit"]["identified"]) == pytest.approx(TRUTH["rampUpLimit"], rel=0.02)
    assert float(params["voltageIntercept"]["identified"]) == pytest.approx(TRUTH["voltageIntercept"], abs=0.05)

    # The FMU in the out directory carries the identified values; the shipped FMU is untouched.
    fmu = tmp_path / "validation" / "AemIdentified.fmu"
    starts = {v.name: v.start for v in read_model_description(str(fmu)).modelVariables if v.causality == "parameter"}
    for name, r in params.items():
        assert float(starts[name]) == float(r["identified"]), name
    if shipped is not None:
        assert hashlib.sha256(FMU_PATH.read_bytes()).hexdigest() == shipped

    d = np.genfromtxt(tmp_path / "validation_day.csv", delimiter=",", skip_header=1)
    time, setpoint, i_meas, i_sim, compared = d[:, 0], d[:, 1], d[:, 2], d[:, 3], d[:, 8] == 1
    # Settled at the end of every level of 900 s or more: the simulated current is K_identified * u.
    change = np.flatnonzero(np.diff(setpoint) != 0)
    ends = np.r_[change, len(setpoint) - 1]
    starts_ = np.r_[0, change + 1]
    settled = [e for s, e in zip(starts_, ends) if time[e] - time[s] >= 900 and compared[e]]
    assert settled, "no long level on the held-out day"
    for e in settled:
        assert i_sim[e] == pytest.approx(float(params["gain"]["identified"]) * setpoint[e], abs=0.01)
    # The held-out RMSE: noise-dominated, and the same as aem-identify validate's.
    rmse = math.sqrt(np.mean((i_meas[compared] - i_sim[compared]) ** 2))
    assert 0.8 * NOISE < rmse < 3 * NOISE
    tool_rmse = float(re.search(r"aem-identify validate: ([0-9.]+) A", out).group(1))
    assert rmse == pytest.approx(tool_rmse, abs=6e-5)
    assert (tmp_path / "validation_day.png").read_bytes()[:4] == b"\x89PNG"


def test_the_cold_start_warms_the_stack_and_costs_what_its_voltage_says(fmu_path, tmp_path):
    """aem_electrolyser.examples.cold_start: the stack starts at the ambient 5 °C with the voltage
    of the curve written out at that temperature, warms, and is held at 55 °C; the paper's
    column is V0 + R*I throughout; the extra energy is the integral of the extra power (the
    trapezoid of the CSV's 10 s rows, within its error)."""
    out = run_example("cold_start", "--fmu", fmu_path, "--out", tmp_path)
    rows = read_rows(tmp_path / "cold_start.csv")
    assert all("[" in name for name in rows[0]), "every column has its unit"
    col = {name: np.array([float(r[name]) for r in rows]) for name in rows[0]}
    v0, r, k = PAPER["voltageIntercept"], PAPER["ohmicResistance"], PAPER["gain"]
    kv, kr = -0.046, -0.0015  # the FMU's start values of the two coefficients
    i0, dt0 = col["current [A]"][0], 5.0 - 55.0
    assert i0 == pytest.approx(k * 60.0, rel=1e-9)
    assert col["voltage [V]"][0] == pytest.approx(v0 + kv * dt0 + (r + kr * dt0) * i0, rel=1e-9)
    np.testing.assert_allclose(col["voltage at 55 degC [V]"], v0 + r * col["current [A]"], rtol=1e-9)  # 10 digits
    temperature = col["stack temperature [degC]"]
    assert np.all(np.diff(temperature) >= -1e-12), "a stack that only heats up here"
    assert temperature[-1] == pytest.approx(55.0, abs=1e-9)
    assert np.all(col["cooling power [W]"][temperature < 55.0 - 1e-9] == 0.0)
    extra = col["energy [J]"][-1] - col["energy at 55 degC [J]"][-1]
    more = col["power [W]"] - col["power at 55 degC [W]"]
    trapezoid = float(np.sum(np.diff(col["time [s]"]) * 0.5 * (more[1:] + more[:-1])))
    assert extra > 0.0
    assert extra == pytest.approx(trapezoid, rel=2e-2)
    assert "reaches 55 °C after" in out and "the cold morning costs" in out


def test_the_winter_week_compares_the_plant_with_the_papers_hub(fmu_path, tmp_path):
    """aem_electrolyser.examples.winter_week on half a day of 8 modules: the paper's hub is at
    55 °C throughout and draws from the grid exactly its electric energy; the plant's stacks
    stay between the coldest air and the setpoint, and its grid energy exceeds its electric
    energy by the supply losses and auxiliaries, so its specific energy on the grid side is
    higher; the KPI table's columns are the three hubs."""
    out = run_example("winter_week", "--fmu", fmu_path, "--out", tmp_path, "--days", "0.5", "--modules", "8")
    rows = read_rows(tmp_path / "winter_week.csv")
    assert all("[" in name for name in rows[0]), "every column has its unit"
    col = {name: np.array([float(r[name]) for r in rows]) for name in rows[0]}
    assert len(rows) == 0.5 * 86400 / 60 + 1
    np.testing.assert_array_equal(col["paper mean stack temperature [degC]"], 55.0)
    coldest = col["ambient temperature [degC]"].min()
    for name in ("plant", "heated"):
        t = col[f"{name} mean stack temperature [degC]"]
        assert np.all(t >= coldest - 1e-9) and np.all(t <= 55.0 + 1e-9), name
    lines = out.splitlines()
    header = next(line for line in lines if line.split() == ["paper", "plant", "heated"])
    table = {}
    for line in lines[lines.index(header) + 1 :]:
        if not line.startswith(("hydrogen", "grid", "supply", "specific", "cold", "warm")):
            break
        key, *values = line.rsplit(None, 3)
        table[key] = dict(zip(("paper", "plant", "heated"), map(float, values)))
    losses = table["supply losses and auxiliaries [MWh]"]
    assert losses["paper"] == 0.0 and losses["plant"] > 0.0 and losses["heated"] > 0.0
    grid, electric = table["specific energy, grid side [kWh/kg]"], table["specific energy, electric [kWh/kg]"]
    assert grid["paper"] == electric["paper"]
    assert grid["plant"] > electric["plant"] and grid["plant"] > grid["paper"]
    for name in ("paper", "plant", "heated"):
        assert table["cold starts [1]"][name] >= 0 and table["warm starts [1]"][name] >= 0
