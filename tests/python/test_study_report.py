"""study/report.py on synthetic study tables whose KPIs follow simple formulas, so the ranges,
best cases and seed means the report states are computed here independently."""
import hashlib
import re

import numpy as np
import pandas as pd
import pytest
from PIL import Image


from aem_electrolyser.study.kpis import KPIS, RUN_COLUMNS
from aem_electrolyser.study.report import layout, pivot, read_csv, write_report

AXES = ["series", "mode", "hub size [%]", "seed", "hysteresis [%]"]
MODES = {"equal": 1.0, "sequential": 0.9}
SIZES = [50.0, 100.0, 150.0]
SEEDS = [1, 2, 3]
FAILED = ("sequential", 50.0, 1)
MESSAGE = "aem-run exited with status 1\nthread 'main' panicked at src/hub.rs:12"
ALL_NAN = "rms tracking error [MW]"
PNG = b"\x89PNG\r\n\x1a\n"


def hydrogen(mode, size, seed):
    """[kg]; largest at equal, 150 %; past a million (printed grouped); a third added so the
    doubles have long expansions."""
    return 10000.0 * size * (1 + 0.01 * seed) * MODES[mode] + 1 / 3


def wind_lost(mode, size, seed):
    """[MWh]; smallest at equal, 150 %."""
    return 5000.0 / size * (1 + 0.1 * seed) / MODES[mode]


def key(*values):
    return hashlib.sha256(repr(values).encode()).hexdigest()[:16]


def row(axes, kpis, failed=False, scenario=None):
    """One table row: axis values, KPIs (NaN when failed), run columns and labels."""
    kpis = {k: np.nan for k in KPIS} if failed else kpis
    return {**axes, **kpis, "run time [s]": 12.5 + len(str(axes)) / 7, "worker": "w1",
            "scenario": scenario or key(*axes.values()),
            "status": "failed" if failed else "done", "message": MESSAGE if failed else ""}


def crossed_table():
    """mode x hub size x seed with two single-valued axes, one failed row, the rows shuffled,
    the columns reordered, and one scenario key that reads as a number."""
    rows = []
    for mode in MODES:
        for size in SIZES:
            for seed in SEEDS:
                h2 = hydrogen(mode, size, seed)
                kpis = {k: (i + 1) * size + seed / 3 for i, k in enumerate(KPIS)}
                kpis.update({"hydrogen [kg]": h2, "wind not absorbed [MWh]": wind_lost(mode, size, seed),
                             "grid import [MWh]": -0.0,        # the sign bit must survive
                             "specific energy [kWh/kg]": 1e-300 * seed, ALL_NAN: np.nan})
                axes = {"series": "wind2019", "mode": mode, "hub size [%]": size, "seed": seed,
                        "hysteresis [%]": 5.0}
                rows.append(row(axes, kpis, failed=(mode, size, seed) == FAILED))
    rows[4]["scenario"] = "000000000000e123"
    table = pd.DataFrame(rows).sample(frac=1.0, random_state=7).reset_index(drop=True)
    return table[list(reversed(table.columns))]


def expected_order(table):
    """The order the report must write, computed without the module."""
    done = sorted(range(len(table)), key=lambda i: tuple(table.loc[i, a] for a in AXES))
    cols = AXES + list(KPIS) + RUN_COLUMNS + ["scenario", "status", "message"]
    return table.loc[done, cols].reset_index(drop=True)


def assert_bitwise(back, want):
    pd.testing.assert_frame_equal(back, want, check_exact=True)
    for c in want.columns:
        if want[c].dtype.kind == "f":
            bits = back[c].to_numpy().view(np.uint64)
            assert (bits == want[c].to_numpy().view(np.uint64)).all(), c


def summary_line(text, start):
    """The one line of the summary that starts (after its indent) with `start`."""
    hits = [line for line in text.splitlines() if line.strip().startswith(start)]
    assert len(hits) == 1, (start, text)
    return hits[0]


def range_line(text, kpi):
    """The line of `kpi` in the summary's KPI ranges."""
    hits = [line for line in text.splitlines() if line.startswith(f"  {kpi}  ")]
    assert len(hits) == 1, (kpi, text)
    return hits[0]


def numbers(line):
    """The numbers in a line of the summary, thousands separators dropped."""
    line = re.sub(r"(?<=\d),(?=\d{3})", "", line)
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]\d+)?", line)]


def assert_png(path, size=(700, 450)):
    assert path.read_bytes()[:8] == PNG
    with Image.open(path) as image:
        image.verify()
    with Image.open(path) as image:
        assert image.size == size
    assert 5_000 < path.stat().st_size < 500_000


@pytest.fixture(scope="module")
def crossed(tmp_path_factory):
    table = crossed_table()
    out = tmp_path_factory.mktemp("study")
    return table, out, write_report(table, AXES, out, "Hub sizing 2019")


def test_tables_read_back_bit_for_bit_in_axis_order(crossed):
    table, out, written = crossed
    want = expected_order(table)
    assert_bitwise(pd.read_parquet(out / "kpis.parquet"), want)
    assert_bitwise(read_csv(out / "kpis.csv"), want)
    # plain pandas with round-trip floats reads the same doubles (the key column aside)
    plain = pd.read_csv(out / "kpis.csv", float_precision="round_trip")
    for k in KPIS:
        np.testing.assert_array_equal(plain[k].to_numpy(), want[k].to_numpy())
    assert (out / "kpis.csv").read_text().splitlines()[0].startswith(
        "series,mode,hub size [%],seed,hysteresis [%],modules [1],")


def test_written_files_and_plots(crossed):
    table, out, written = crossed
    on_disk = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert on_disk == set(written)
    assert all(written[name] == out / name for name in written)
    plots = {name for name in written if name.startswith("plots/")}
    assert plots == {f"plots/{s}.png" for s in (
        "modules_1", "hub_rated_power_MW", "horizon_h", "reference_energy_MWh", "energy_drawn_MWh",
        "hydrogen_kg", "specific_energy_kWh_per_kg", "wind_not_absorbed_MWh", "grid_import_MWh",
        "full-load_hours_h", "starts_per_module_1", "running_hours_per_module_h")}
    for name in plots:
        assert_png(out / name)


def test_layout_of_the_crossed_study(crossed):
    table = crossed[0]
    lay = layout(table, AXES)
    assert (lay.x, lay.lines, lay.replicates) == ("hub size [%]", ["mode"], ["seed"])
    assert not lay.categorical


def test_summary_counts_failures_ranges_and_best_cases(crossed):
    table, out, _ = crossed
    text = (out / "summary.txt").read_text()
    assert text.startswith("Study: Hub sizing 2019\nScenarios: 17 done, 1 failed (18 in all)")
    failed = summary_line(text, "series=wind2019, mode=sequential, hub size [%]=50, seed=1")
    assert failed.endswith("aem-run exited with status 1") and "panicked" not in text
    done = [(m, s, d) for m in MODES for s in SIZES for d in SEEDS if (m, s, d) != FAILED]
    for name, f in (("hydrogen [kg]", hydrogen), ("wind not absorbed [MWh]", wind_lost)):
        line = range_line(text, name)
        lo, hi = numbers(line.removeprefix(f"  {name}"))
        assert lo == pytest.approx(min(f(*c) for c in done), rel=1e-5)
        assert hi == pytest.approx(max(f(*c) for c in done), rel=1e-5)
        assert line.endswith(name.split("[")[1].rstrip("]"))
    assert range_line(text, ALL_NAN).endswith("no values")
    best = summary_line(text, "largest hydrogen [kg]")
    assert best.endswith("kg at hub size [%]=150, mode=equal")
    mean = np.mean([hydrogen("equal", 150.0, d) for d in SEEDS])
    assert numbers(best.split(":")[1])[0] == pytest.approx(mean, rel=1e-5)
    best = summary_line(text, "smallest wind not absorbed [MWh]")
    assert best.endswith("MWh at hub size [%]=150, mode=equal")
    assert "Best cases (mean over seed):" in text
    assert "1,530,000 kg at" in text


def test_pivot_is_the_seed_mean(crossed):
    table, out, _ = crossed
    frame = pivot(table, AXES)
    assert list(frame.index) == SIZES and list(frame.columns) == list(MODES)
    for mode in MODES:
        for size in SIZES:
            seeds = [d for d in SEEDS if (mode, size, d) != FAILED]
            mean = np.mean([hydrogen(mode, size, d) for d in seeds])
            assert frame.loc[size, mode] == pytest.approx(mean, rel=1e-14)
    text = (out / "summary.txt").read_text()
    heading = "Mean hydrogen [kg] over seed by hub size [%] (rows) and mode (columns):\n"
    lines = text.split(heading)[1].splitlines()
    assert lines[0].split() == ["mode", "equal", "sequential"]
    for size, line in zip(SIZES, lines[2:]):
        assert numbers(line) == pytest.approx([size] + [frame.loc[size, m] for m in MODES], rel=1e-6)


def test_plots_off(tmp_path):
    written = write_report(crossed_table(), AXES, tmp_path, "no plots", plots=False)
    assert set(written) == {"kpis.parquet", "kpis.csv", "summary.txt"}
    assert not (tmp_path / "plots").exists()


def test_a_single_scenario(tmp_path):
    kpis = {k: 2.0 + i / 7 for i, k in enumerate(KPIS)}
    table = pd.DataFrame([row({"mode": "equal", "hub size [%]": 100.0}, kpis)])
    written = write_report(table, ["mode", "hub size [%]"], tmp_path, "one run")
    assert_bitwise(read_csv(written["kpis.csv"]), table)
    assert sum(name.startswith("plots/") for name in written) == len(KPIS)
    assert_png(written["plots/hydrogen_kg.png"])
    text = written["summary.txt"].read_text()
    assert "Scenarios: 1 done, 0 failed (1 in all)" in text and "Failed scenarios: none" in text
    h2 = kpis["hydrogen [kg]"]
    span = numbers(range_line(text, "hydrogen [kg]").removeprefix("  hydrogen [kg]"))
    assert span == pytest.approx([h2, h2], rel=1e-5)
    assert summary_line(text, "largest hydrogen [kg]").endswith("at mode=equal")
    assert pivot(table, ["mode", "hub size [%]"]).loc["equal", "hydrogen [kg]"] == h2


def test_only_categorical_axes(tmp_path):
    """mode x dispatch x series: mode is x (categories), dispatch the lines, series averaged."""
    axes = ["mode", "dispatch", "series"]
    rows = []
    for m, mode in enumerate(["sequential", "equal"]):
        for d, dispatch in enumerate(["merit", "roundRobin"]):
            for s, series in enumerate(["NA", "wind2020"]):
                kpis = {k: 10.0 * m + d + 0.5 * s + i for i, k in enumerate(KPIS)}
                kpis["wind not absorbed [MWh]"] = np.nan   # a setpoint-driven study
                rows.append(row({"mode": mode, "dispatch": dispatch, "series": series}, kpis))
    table = pd.DataFrame(rows)
    written = write_report(table, axes, tmp_path, "dispatch rules")
    lay = layout(table, axes)
    assert (lay.x, lay.lines, lay.replicates, lay.categorical) == ("mode", ["dispatch"], ["series"], True)
    back = read_csv(written["kpis.csv"])
    assert back.loc[0, "series"] == "NA" and list(back["mode"][:4]) == ["equal"] * 4
    assert "plots/wind_not_absorbed_MWh.png" not in written
    assert_png(written["plots/hydrogen_kg.png"])
    frame = pivot(table, axes)
    base = list(KPIS).index("hydrogen [kg]")
    assert frame.loc["sequential", "roundRobin"] == base + 1 + 0.25
    assert frame.loc["equal", "merit"] == base + 10 + 0.25
    text = written["summary.txt"].read_text()
    assert summary_line(text, "largest hydrogen [kg]").endswith("at mode=equal, dispatch=roundRobin")
    assert range_line(text, "wind not absorbed [MWh]").endswith("no values")
    assert "  wind not absorbed [MWh]: no values" in text


def test_many_lines_split_into_subplots(tmp_path):
    """2 modes x 7 hysteresis values = 14 lines > 12: one panel per mode, wider than 7 in."""
    rows = [row({"mode": mode, "hysteresis [%]": float(h), "hub size [%]": size},
                {k: size * (1 + h / 10) * f for k in KPIS})
            for mode, f in MODES.items() for h in range(7) for size in SIZES]
    axes = ["mode", "hub size [%]", "hysteresis [%]"]
    table = pd.DataFrame(rows)
    assert layout(table, axes).lines == ["mode", "hysteresis [%]"]
    written = write_report(table, axes, tmp_path, "split")
    with Image.open(written["plots/hydrogen_kg.png"]) as image:
        assert image.size == (840, 400)


def test_all_failed(tmp_path):
    table = pd.DataFrame([row({"mode": m, "seed": s}, {}, failed=True)
                          for m in MODES for s in SEEDS])
    written = write_report(table, ["mode", "seed"], tmp_path, "broken")
    assert not any(name.startswith("plots/") for name in written)
    text = written["summary.txt"].read_text()
    assert "0 done, 6 failed" in text and text.count("aem-run exited with status 1") == 6
    assert "  hydrogen [kg]: no values" in text and "Mean hydrogen" not in text
