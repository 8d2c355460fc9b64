"""The reserve table over the base power (aem_electrolyser.reserves.operating_table), on the
packaged FMU: a small hub's downward FCR-D, whose every capacity stays under the window's bound
and under the rising-current limit's (both in closed form here), and whose best configuration,
assessed again from scratch, sells what the table says."""

import csv
import json

import pytest

from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, dispatch_search
from aem_electrolyser.reserves.prequalify import BELOW_MINIMUM
from aem_electrolyser.reserves.products import BY_NAME
from commands import run
from conftest import PAPER

N, BASELINE, DT = 10, 0.5, 0.2


def closed_form_ramp_bound():
    """max over the running counts n of n·min(P(M) − B/n, P(I + r·7.5 s) − B/n)/0.86 [W]."""
    power = lambda i: (PAPER["voltageIntercept"] + PAPER["ohmicResistance"] * i) * i  # noqa: E731
    rated = N * power(PAPER["gain"] * PAPER["maxSetpoint"])
    base, best = BASELINE * rated, 0.0
    for n in range(1, N + 1):
        share = base / n
        if not power(PAPER["gain"] * PAPER["minSetpoint"]) <= share <= rated / N:
            continue
        # The current at which the module draws B/n: the positive root of (V0 + R·I)·I = B/n.
        i = (
            -PAPER["voltageIntercept"] + (PAPER["voltageIntercept"] ** 2 + 4 * PAPER["ohmicResistance"] * share) ** 0.5
        ) / (2 * PAPER["ohmicResistance"])
        rise = min(rated / N, power(i + PAPER["rampUpLimit"] * 7.5)) - share
        best = max(best, n * rise / 0.86)
    return best, rated


@pytest.fixture(scope="module")
def table(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("table")
    done = run(
        [
            "-m",
            "aem_electrolyser.reserves.operating_table",
            "--fmu",
            fmu_path,
            "--modules",
            N,
            "--baseline",
            100 * BASELINE,
            "--products",
            "FCR-D down",
            "--dt",
            DT,
            "--no-plots",
            "--out",
            out,
        ],
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    with open(out / "table.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return out, rows, json.loads((out / "table.json").read_text())


def test_every_capacity_stays_under_the_physical_bounds(table):
    _, rows, records = table
    # Units in every header but the names.
    assert len(rows) == 1 and all("[" in name for name in rows[0] if name not in ("product", "reference dispatch"))
    (row,) = records
    bound, rated = closed_form_ramp_bound()
    assert row["ramp bound [W]"] == pytest.approx(bound, rel=1e-9)
    assert row["window bound [W]"] == pytest.approx(rated * (1 - BASELINE), rel=1e-12)
    for column in ("plain", "compensated", "control", "dispatch", "both"):
        assert 0.0 <= row[f"{column} [W]"] <= row["ramp bound [W]"], column
    # Below equal dispatch's reach plain droop runs the fewest modules, all at maxSetpoint: no
    # room to draw more within 7.5 s. A lever sells some, and both together at least as much.
    assert row["reference dispatch"] == "sequential" and row["plain [W]"] == 0.0
    assert max(row["control [W]"], row["dispatch [W]"]) > 0.0
    assert row["both [W]"] >= max(row["control [W]"], row["dispatch [W]"])


def test_the_best_configuration_sells_what_the_table_says_when_assessed_anew(fmu_path, table):
    (row,) = table[2]
    count, zero = row["both: count [1]"], row["both: zero [s]"]
    plain = zero == pytest.approx(PAPER["tauZero"], rel=1e-12)
    if count is None:  # the control alone won, with the reference dispatch
        policy = {"equal": 1, "sequential": 2}[row["reference dispatch"]]
        hub = Hub(N, policy, BELOW_MINIMUM[policy], BASELINE, filter_zero=0.0 if plain else zero)
    else:
        curve = dispatch_search.ModuleCurve(
            PAPER["gain"],
            PAPER["voltageIntercept"],
            PAPER["ohmicResistance"],
            PAPER["minSetpoint"],
            PAPER["maxSetpoint"],
        )
        rated = N * curve.power(curve.max_setpoint)
        target = dispatch_search.target_setpoint(count, BASELINE * rated, curve)
        hub = Hub(N, 4, 1, BASELINE, filter_zero=0.0 if plain else zero, dispatch_target=target)
    runner = HubRunner(fmu_path, hub)
    try:
        result = assess.largest(runner, BY_NAME["FCR-D down"], DT)[0]
    finally:
        runner.close()
    assert result.sellable == pytest.approx(row["both [W]"], rel=1e-12)
