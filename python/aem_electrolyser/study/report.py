"""The report of a study: its table (`kpis.parquet`, `kpis.csv`), one PNG per KPI against the
axes (`plots/`), and `summary.txt`, the page a planner reads first.

The CSV's floats are written by pandas' shortest round-trip repr: `read_csv` below (or pandas
with `float_precision="round_trip"`) reads back the same doubles. Replicate axes (`seed`,
`series`) are averaged over in the plots, best cases and pivot, their min-max shown as spread.

What the report does not let pass silently:
- a best case comes with what it took: its grid import (MWh and share of the grid energy), the
  wind it left (MWh and share of the wind offered) and its starts (per module and in all);
- a categorical x axis (dispatch = equal, sequential; seeds; series) is drawn as grouped bars,
  never as a line sloping from one category to the next (plot_kind);
- a KPI or axis with one value over all scenarios is not plotted; the summary names it and its
  value under "Constant over the scenarios".
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from .kpis import KPIS, RUN_COLUMNS  # noqa: E402

#: Axes whose values are replicates of one configuration, not choices of a planner.
REPLICATES = ("seed", "series")
#: More line combinations than this are split into subplots by the first line axis.
MAX_LINES = 12
#: KPIs with a best case in the summary, and whether larger is better.
BEST = {"hydrogen [kg]": True, "wind not absorbed [MWh]": False}
#: The KPIs a best case's caveats are made of (kpis.KPIS).
GRID, DRAWN = "grid import [MWh]", "grid energy [MWh]"
LOST, OFFERED = "wind not absorbed [MWh]", "reference energy [MWh]"
STARTS, MODULES = "starts per module [1]", "modules [1]"
PIVOT_KPI = "hydrogen [kg]"
LABELS = ["scenario", "status", "message"]


@dataclass(frozen=True)
class Layout:
    """How KPIs are drawn against the axes: `x` on the horizontal axis (None: the study has no
    axis), one line per combination of `lines`, mean and min-max over `replicates`."""

    x: Optional[str]
    lines: list
    replicates: list
    categorical: bool


def _numeric(column: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column)


def constant_axes(table: pd.DataFrame, axes: list) -> list:
    """The axes with one value over all scenarios (not drawn: stated in the summary)."""
    return [a for a in axes if table[a].nunique(dropna=False) <= 1]


def layout(table: pd.DataFrame, axes: list) -> Layout:
    """x: the first numeric varying non-replicate axis, else the first varying one (categories);
    if only replicates vary, the first of them; if nothing varies, the first axis. x is
    categorical unless it is a numeric axis of choices that varies (a seed or a series is a
    name: seeds 1, 2, 3 are not a scale)."""
    varying = [a for a in axes if a not in constant_axes(table, axes)]
    choices = [a for a in varying if a not in REPLICATES]
    candidates = choices or [a for a in varying if a in REPLICATES] or axes[:1]
    x = next((a for a in candidates if _numeric(table[a])), candidates[0] if candidates else None)
    return Layout(
        x,
        [a for a in choices if a != x],
        [a for a in varying if a in REPLICATES and a != x],
        x is None or not _numeric(table[x]) or x in REPLICATES or x not in varying,
    )


def plot_kind(lay: Layout) -> str:
    """ "bars" (grouped by the line axes) for a categorical x, "lines" for a numeric one: a line
    joins only values of a scale."""
    return "bars" if lay.categorical else "lines"


def constant_kpis(table: pd.DataFrame) -> dict:
    """KPI -> its one value, for the KPIs with the same value in every done scenario (at least
    one; a KPI without values, or without one in some scenario, is not constant)."""
    done = table[table["status"] == "done"]
    out = {}
    for kpi in [k for k in KPIS if k in done]:
        values = done[kpi].astype(float)
        if len(values) and values.notna().all() and values.min() == values.max():
            out[kpi] = values.iloc[0]
    return out


def ordered(table: pd.DataFrame, axes: list) -> pd.DataFrame:
    """Rows sorted by the axes in the study's order (stable); columns: axes, KPIs, run
    columns, scenario, status, message, then any others."""
    rows = table.sort_values(axes, kind="mergesort") if axes else table
    first = list(axes) + [c for c in [*KPIS, *RUN_COLUMNS, *LABELS] if c in table]
    return rows[first + [c for c in table if c not in first]].reset_index(drop=True)


def read_csv(path: Path) -> pd.DataFrame:
    """kpis.csv as written: exact doubles, only empty cells as NaN (a series may be called
    "NA"), scenario keys as strings (a hex key such as "12e4" is no number), messages ""."""
    table = pd.read_csv(
        path, float_precision="round_trip", keep_default_na=False, na_values=[""], dtype={c: str for c in LABELS}
    )
    return table.fillna({"message": ""})


def _fmt(value) -> str:
    """An axis value or KPI as a planner reads it: floats with 6 significant digits, from a
    million on whole and grouped by thousands (15,234,567 kg, not 1.52346e+07)."""
    if not isinstance(value, float):
        return str(value)
    if math.isnan(value):
        return "–"
    value = value + 0.0  # -0.0 reads as 0
    return f"{value:,.0f}" if 1e6 <= abs(value) < 1e15 else f"{value:.6g}"


def _unit(kpi: str) -> str:
    """The unit in a column's name ("hydrogen [kg]" -> "kg"); "1" (a count) reads as none."""
    found = re.search(r"\[(.*)\]\s*$", kpi)
    return "" if found is None or found.group(1) == "1" else found.group(1)


def _where(row, names) -> str:
    return ", ".join(f"{a}={_fmt(row[a])}" for a in names)


def slug(kpi: str) -> str:
    """A KPI's file name stem: "specific energy [kWh/kg]" -> "specific_energy_kWh_per_kg"."""
    return re.sub(r"[^A-Za-z0-9.-]+", "_", kpi.replace("/", " per ")).strip("_")


def stats(table: pd.DataFrame, lay: Layout, kpi: str) -> pd.DataFrame:
    """Mean, min and max of `kpi` over the replicates of each (x, lines) combination of the
    done scenarios, sorted by x then lines."""
    done = table[table["status"] == "done"]
    keys = [a for a in (lay.x, *lay.lines) if a]
    if not keys:
        return done[kpi].agg(["mean", "min", "max"]).to_frame().T
    return done.groupby(keys, sort=True)[kpi].agg(["mean", "min", "max"]).reset_index()


def pivot(table: pd.DataFrame, axes: list, kpi: str = PIVOT_KPI) -> pd.DataFrame:
    """Mean of `kpi` over the replicates: rows the x axis' values, columns the lines'."""
    lay = layout(table, axes)
    means = stats(table, lay, kpi)
    if lay.x is None:
        return means[["mean"]].rename(columns={"mean": kpi})
    if not lay.lines:
        return means.set_index(lay.x)[["mean"]].rename(columns={"mean": kpi})
    return means.pivot(index=lay.x, columns=lay.lines, values="mean")


def _panels(n: int):
    """A figure of n panels sharing y: 7 x 4.5 in for one, a grid of up to 3 columns else."""
    cols = min(n, 3)
    rows = -(-n // cols)
    size = (7, 4.5) if n == 1 else (min(4.2 * cols, 13), 3.2 * rows + 0.8)
    fig, axs = plt.subplots(rows, cols, figsize=size, sharey=True, squeeze=False)
    for ax in axs.flat[n:]:
        ax.set_visible(False)
    return fig, list(axs.flat[:n])


def _draw(ax, x, line: pd.DataFrame, label, i: int, spread: bool):
    """One line of means over a numeric x; the min-max over replicates as a band."""
    color = f"C{i % 10}"
    ax.plot(x, line["mean"], marker="o", ms=4, color=color, ls="-" if i < 10 else "--", label=label)
    if spread:
        ax.fill_between(x, line["min"], line["max"], color=color, alpha=0.2, lw=0)


def _bars(ax, x, line: pd.DataFrame, label, i: int, n: int, spread: bool):
    """Group member i of n at each category position x: a bar of the mean, the min-max over
    replicates as an error bar."""
    line = line.assign(at=np.asarray(x, dtype=float) + (i - (n - 1) / 2) * 0.8 / n).dropna(subset=["mean"])
    ax.bar(
        line["at"], line["mean"], width=0.8 / n * 0.92, color=f"C{i % 10}", label=label, hatch=None if i < 10 else "//"
    )
    if spread:
        ax.errorbar(
            line["at"],
            line["mean"],
            yerr=[line["mean"] - line["min"], line["max"] - line["mean"]],
            fmt="none",
            ecolor="0.2",
            capsize=3,
            lw=1,
        )


def _split(table: pd.DataFrame, means: pd.DataFrame, lay: Layout) -> list:
    """(panel title, its rows of `means`, its line axes): one panel, or one per value of the
    first line axis when there are more than MAX_LINES combinations of lines."""
    if not lay.lines or len(table[lay.lines].drop_duplicates()) <= MAX_LINES:
        return [(None, means, lay.lines)]
    first = lay.lines[0]
    return [(f"{first}={_fmt(v)}", means[means[first] == v], lay.lines[1:]) for v in sorted(table[first].unique())]


def _x(line: pd.DataFrame, lay: Layout, cats: Optional[list]):
    """Positions on the x axis: the x axis' values, or the indices of its categories."""
    if cats is None:
        return line[lay.x]
    return line[lay.x].map(cats.index) if lay.x else [0] * len(line)


def figure(table: pd.DataFrame, lay: Layout, kpi: str, title: str):
    """The matplotlib figure of `kpi` against x (see plot_kind): one line, or one bar of each
    group, per combination of the line axes (subplots by the first line axis past MAX_LINES
    combinations), mean and spread over the replicates. The caller closes it."""
    means = stats(table, lay, kpi)
    cats = (sorted(table[lay.x].unique()) if lay.x else ["all"]) if plot_kind(lay) == "bars" else None
    parts = _split(table, means, lay)
    fig, axs = _panels(len(parts))
    for ax, (name, part, inner) in zip(axs, parts):
        lines = list(part.groupby(inner, sort=True)) if inner else [(None, part)]
        for i, (key, line) in enumerate(lines):
            key = key if key is None or isinstance(key, tuple) else (key,)
            label = None if key is None else _where(dict(zip(inner, key)), inner)
            if cats is None:
                _draw(ax, _x(line, lay, cats), line, label, i, bool(lay.replicates))
            else:
                _bars(ax, _x(line, lay, cats), line, label, i, len(lines), bool(lay.replicates))
        ax.set_axisbelow(True)
        if cats:
            ax.set_xticks(range(len(cats)), [_fmt(c) for c in cats])
            ax.set_xlim(-0.5, len(cats) - 0.5)
        ax.set(xlabel=lay.x or "", ylabel=kpi)
        ax.set_title(name or "", fontsize=9)
        ax.grid(alpha=0.3)
        if inner:
            ax.legend(fontsize=7)
    spread = f"\nmean over {', '.join(lay.replicates)}; spread: min–max" if lay.replicates else ""
    fig.suptitle(f"{kpi} — {title}{spread}", fontsize=10)
    fig.tight_layout()
    return fig


def plot_kpi(table: pd.DataFrame, lay: Layout, kpi: str, title: str, path: Path) -> Path:
    """The figure of `kpi` written to `path` (PNG)."""
    fig = figure(table, lay, kpi, title)
    try:
        fig.savefig(path, dpi=100)
    finally:
        plt.close(fig)
    return path


def _axis_values(table: pd.DataFrame, axis: str) -> str:
    values = sorted(table[axis].unique())
    shown = values if len(values) <= 6 else [values[0], "…", values[-1]]
    count = "1 value" if len(values) == 1 else f"{len(values)} values"
    return f"{axis}: {', '.join(_fmt(v) for v in shown)} ({count})"


def _over(lay: Layout) -> str:
    return f" over {', '.join(lay.replicates)}" if lay.replicates else ""


def _failures(table: pd.DataFrame, axes: list) -> list:
    """One line per failed scenario: its axis values, key and the first line of its message."""
    failed = table[table["status"] != "done"]
    out = ["Failed scenarios:" if len(failed) else "Failed scenarios: none"]
    for _, row in failed.iterrows():
        message = (str(row["message"]).strip().splitlines() or ["(no message)"])[0]
        out.append(f"  {_where(row, axes)} [{row['scenario']}]: {message}")
    return out


def _ranges(done: pd.DataFrame) -> list:
    """min … max of each KPI over the done scenarios, with its unit."""
    out = ["KPI ranges over the done scenarios (min … max):"]
    for kpi in [k for k in KPIS if k in done]:
        lo, hi = done[kpi].min(), done[kpi].max()
        span = "no values" if pd.isna(lo) else f"{_fmt(lo)} … {_fmt(hi)} {_unit(kpi)}".rstrip()
        out.append(f"  {kpi:<32} {span}")
    return out


def _share(part: float, whole: float) -> str:
    return f"{100 * part / whole:.3g} %" if whole else "–"


def caveats(rows: pd.DataFrame) -> list:
    """What a configuration's result took, from its done scenarios `rows` (means over them):
    grid import with its share of the grid energy, wind not absorbed with its share of the
    wind offered, starts per module and in all. A KPI without values (a setpoint series has no
    wind) is left out."""
    mean = {
        k: rows[k].astype(float).mean() if k in rows else np.nan for k in (GRID, DRAWN, LOST, OFFERED, STARTS, MODULES)
    }
    out = []
    if not pd.isna(mean[GRID]):
        of = (
            ""
            if pd.isna(mean[DRAWN])
            else f", {_share(mean[GRID], mean[DRAWN])} of the {_fmt(mean[DRAWN])} {_unit(DRAWN)} drawn from the grid"
        )
        out.append(f"grid import: {_fmt(mean[GRID])} {_unit(GRID)}{of}")
    if not pd.isna(mean[LOST]):
        of = (
            ""
            if pd.isna(mean[OFFERED])
            else f", {_share(mean[LOST], mean[OFFERED])} of the {_fmt(mean[OFFERED])} {_unit(OFFERED)} offered"
        )
        out.append(f"wind not absorbed: {_fmt(mean[LOST])} {_unit(LOST)}{of}")
    if not pd.isna(mean[STARTS]):
        total = (
            ""
            if pd.isna(mean[MODULES])
            else f", {_fmt(float((rows[STARTS].astype(float) * rows[MODULES].astype(float)).mean()))} in all"
        )
        out.append(f"starts: {_fmt(mean[STARTS])} per module{total}")
    return out


def _best(table: pd.DataFrame, lay: Layout) -> list:
    """The configuration (mean over the replicates) with the most hydrogen, the least wind lost,
    each with its caveats (grid import, wind not absorbed, starts)."""
    out = [
        f"Best cases (mean{_over(lay)}), with what they took:" if lay.replicates else "Best cases, with what they took:"
    ]
    done = table[table["status"] == "done"]
    keys = [a for a in (lay.x, *lay.lines) if a]
    for kpi, larger in BEST.items():
        means = stats(table, lay, kpi).dropna(subset=["mean"]) if kpi in table else []
        if not len(means):
            out.append(f"  {kpi}: no values")
            continue
        best = means.loc[means["mean"].idxmax() if larger else means["mean"].idxmin()]
        where = _where(best, keys)
        where = f"at {where}" if where else "(one scenario)"
        out.append(f"  {'largest' if larger else 'smallest'} {kpi}: {_fmt(best['mean'])} {_unit(kpi)} {where}")
        rows = done[np.logical_and.reduce([done[a] == best[a] for a in keys])] if keys else done
        out += [f"    {line}" for line in caveats(rows)]
    return out


def _constants(table: pd.DataFrame, axes: list) -> list:
    """The axes and KPIs with one value over all scenarios, which have no plot."""
    axes = constant_axes(table, axes)
    kpis = constant_kpis(table)
    if not axes and not kpis:
        return []
    out = ["Constant over the scenarios (not plotted):"]
    out += [f"  {a} = {_fmt(table[a].iloc[0])}" for a in axes]
    if (table["status"] == "done").sum() == 1:
        return out + ["  every KPI (one scenario done: its values are the ranges above)"]
    out += [f"  {k} = {_fmt(float(v))} {_unit(k)}".rstrip() for k, v in kpis.items()]
    return out


def _pivot_text(table: pd.DataFrame, axes: list, lay: Layout) -> list:
    """The pivot of PIVOT_KPI as text, its values and the x axis' values formatted."""
    if PIVOT_KPI not in table or table.loc[table["status"] == "done", PIVOT_KPI].isna().all():
        return []
    frame = pivot(table, axes).map(_fmt)
    frame.index = frame.index.map(_fmt) if lay.x else [""]
    cols = f" (rows) and {', '.join(lay.lines)} (columns)" if lay.lines else ""
    by = f" by {lay.x}{cols}" if lay.x else ""
    return [f"Mean {PIVOT_KPI}{_over(lay)}{by}:"] + ["  " + line for line in frame.to_string().splitlines()]


def summary(table: pd.DataFrame, axes: list, title: str) -> str:
    """The plain-text summary: counts, axes, failures, KPI ranges, what is constant, best cases
    with their caveats and the pivot."""
    lay = layout(table, axes)
    done = table[table["status"] == "done"]
    head = [
        f"Study: {title}",
        f"Scenarios: {len(done)} done, {len(table) - len(done)} failed ({len(table)} in all)",
        "",
        "Axes:" if axes else "Axes: none",
    ]
    head += [f"  {_axis_values(table, a)}" for a in axes]
    parts = [
        head,
        _failures(table, axes),
        _ranges(done),
        _constants(table, axes),
        _best(table, lay),
        _pivot_text(table, axes, lay),
    ]
    return "\n\n".join("\n".join(p) for p in parts if p) + "\n"


def write_report(
    table: pd.DataFrame, axes: list[str], out_dir: Path, title: str, plots: bool = True
) -> dict[str, Path]:
    """Write kpis.parquet, kpis.csv, summary.txt and (if `plots`) plots/<slug>.png for each
    KPI with a finite value that is not constant (constant_kpis) into out_dir; returns {path
    relative to out_dir: path}."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = ordered(table, list(axes))
    written = {"kpis.parquet": out / "kpis.parquet", "kpis.csv": out / "kpis.csv", "summary.txt": out / "summary.txt"}
    table.to_parquet(written["kpis.parquet"], index=False)
    table.to_csv(written["kpis.csv"], index=False)
    written["summary.txt"].write_text(summary(table, list(axes), title), encoding="utf-8")
    if plots:
        lay = layout(table, list(axes))
        done = table[table["status"] == "done"]
        constant = constant_kpis(table)
        for kpi in [k for k in KPIS if k in table and k not in constant]:
            if np.isfinite(done[kpi].to_numpy(dtype=float)).any():
                (out / "plots").mkdir(exist_ok=True)
                name = f"plots/{slug(kpi)}.png"
                written[name] = plot_kpi(table, lay, kpi, title, out / name)
    return written
