"""The prequalification command on the packaged FMU, against closed forms.

A 100-module equal hub at 80 % of its rated power: mFRR up is limited by the operating window
alone (baseline − every module at 60 %); FFR passes at no capacity (by 1.3 s after the trigger
even the compensated first order K/(τp1 s + 1) has covered only 1 − e^(−1.3/τp1) = 48 %); with
compensation, Continental FCR is limited by the rising-current ramp over its 30 s (the current
rises r·30 s, so C = N·(P(I_b + 30 r) − P_b)/(1 − tolerance)); the reports carry the statement
that they are a model-based assessment, every requirement with its limit, and the summary.
"""
import csv
import json
import math
import subprocess
import sys

import pytest

from conftest import PAPER, ROOT, module_power, setpoint_for

N = 100
K, RAMP = PAPER["gain"], PAPER["rampUpLimit"]


@pytest.fixture(scope="module")
def assessed(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("prequalification")
    done = subprocess.run(
        [sys.executable, "-m", "aem_electrolyser.reserves.prequalify", "--fmu", str(fmu_path), "--modules", str(N), "--baseline", "80",
         "--products", "mFRR up,FFR 49.7 Hz,Continental FCR", "--out", str(out), "--jobs", "2"],
        cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    with open(out / "summary.csv", newline="") as f:
        rows = {(r["product"], r["compensation"]): r for r in csv.DictReader(f)}
    return out, rows, done.stdout


def capacity(rows, product, compensation):
    return float(rows[(product, compensation)]["largest capacity [W]"])


def test_mfrr_up_is_limited_by_the_window_alone(assessed):
    _, rows, _ = assessed
    rated = N * module_power(100.0)
    bound = 0.8 * rated - N * module_power(60.0)
    for compensation in ("off", "on"):
        assert capacity(rows, "mFRR up", compensation) == pytest.approx(bound, abs=1.0)
        assert rows[("mFRR up", compensation)]["limiting requirement"] == "operating window"


def test_ffr_passes_at_no_capacity(assessed):
    _, rows, _ = assessed
    assert 1 - math.exp(-1.3 / PAPER["tauPole1"]) < 0.5
    for compensation in ("off", "on"):
        assert capacity(rows, "FFR 49.7 Hz", compensation) == 0.0
        assert "full activation time" in rows[("FFR 49.7 Hz", compensation)]["limiting requirement"]


def test_compensated_continental_fcr_is_limited_by_the_ramp_over_30_s(assessed):
    _, rows, _ = assessed
    rated = N * module_power(100.0)
    base = 0.8 * rated / N
    i_b = K * setpoint_for(base)
    ramped = N * (module_power((i_b + 30.0 * RAMP) / K) - base)
    tolerance = 0.05  # the power-measurement accuracy class of capacities below 1.5 MW
    limit = ramped / (1 - tolerance)
    found = capacity(rows, "Continental FCR", "on")
    step = 0.005 * rated  # the bisection's resolution
    assert limit - step <= found <= limit + 1e-6 * limit, (found, limit)
    assert "down (50.2 Hz): full activation within 30 s" in rows[("Continental FCR", "on")]["limiting requirement"]
    # Without compensation the slow pole leaves 16 % of a step for τp2 = 114 s: nothing passes.
    assert capacity(rows, "Continental FCR", "off") == 0.0


def test_reports_state_what_they_are_and_every_requirement(assessed):
    out, rows, stdout = assessed
    for mode in ("plain", "compensated"):
        md = (out / f"equal_80pct_{mode}.md").read_text()
        assert "model-based assessment of the test programme" in md and "not a prequalification approval" in md
        assert "Nordic FCR technical requirements v1.1 of 28 March 2025" in md
        doc = json.loads((out / f"equal_80pct_{mode}.json").read_text())
        for test in doc["tests"]:
            assert test["requirements"], test["name"]
            for r in test["requirements"]:
                assert r["status"] in ("pass", "fail", "unsure") and "unit" in r
    assert len(rows) == 6
    assert (out / "summary.md").is_file() and "hub(s)" in stdout
    assert list(out.glob("equal_80pct_compensated_continental_fcr_*.png"))
