"""Reports of evaluated tests: Markdown, CSV and JSON, and PNG plots (matplotlib Agg) in the
style of the TSOs' evaluation tool: frequency; asked and delivered power; limits as lines and
bands; a Nyquist plot with the 0.43 circle for sine tests.
"""

from __future__ import annotations

import csv
import json
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from . import frequency_domain as fd
from .requirement import FAIL, PASS, UNSURE, Requirement, Trace, at, mean
from .signals import UP, TestSignal, asked_response

DISCLAIMER = (
    "This is a model-based assessment of the test programme (Nordic FCR technical "
    "requirements v1.1 of 28 March 2025 and test programme, Fingrid FFR, SO GL "
    "Annex V), not a prequalification approval."
)


@dataclass
class Section:
    """One evaluated test: its name, requirements, the capacity tested [W] and, if searched,
    the bisection result (bisection.CapacityResult), whether reduction factors may lower the
    capacity, and the plots drawn of it (file names)."""

    name: str
    results: Sequence[Requirement]
    capacity: Optional[float] = None
    capacity_result: object = None
    notes: list = field(default_factory=list)
    use_reduction: bool = False
    plots: list = field(default_factory=list)
    margins: list = field(default_factory=list)
    readings: list = field(default_factory=list)


def _cell(x) -> str:
    """A Markdown table cell: pipes escaped (|G_c|, |ΔP_nadir| …)."""
    return str(x).replace("|", "\\|")


@dataclass
class Capacity:
    """A product's capacity as every output states it: `w` the sellable capacity [W] (the
    largest passing capacity, times the reduction factor where the rules allow one), rounded to
    whole watts, and `pct` its % of rated power (2 decimals); `before_reduction_w` [W] and
    `reduction_factor` only when a reduction factor applies; `limiting` the limiting
    requirement(s) by name, `detail` each with its measured value against its limit (or the
    operating window's bound); `tested` what the shown requirements were evaluated at."""

    w: float
    pct: float
    before_reduction_w: Optional[float]
    reduction_factor: Optional[float]
    limiting: str
    detail: str
    tested: str


def _by_name(results, name):
    return next((r for r in results if r.name == name), None)


def _measured(r: Requirement) -> str:
    return f"{r.measured:.6g} {r.unit}".strip()


def capacity(sec: Section, rated: float) -> Optional[Capacity]:
    """The capacity figures of a searched section (None if it was not searched)."""
    cr = sec.capacity_result
    if cr is None:
        return None
    w = float(round(cr.sellable))
    pct = round(100.0 * w / rated, 2)
    k = cr.reduction_factor
    before = float(round(cr.capacity)) if k is not None else None
    if getattr(cr, "window_empty", False):
        limiting = "operating window"
        detail = (
            f"operating window: it allows no capacity in this direction at this baseline "
            f"(bound {cr.upper:.0f} W); not tested"
        )
    elif cr.upper_bound_passes:
        limiting = "operating window"
        detail = f"operating window: every requirement passes at its bound, {cr.capacity:.0f} W"
        if k is not None:
            detail += f" (with the reduction factor K_red = {k:.4f}: {w:.0f} W to sell)"
        detail += "; a larger capacity does not fit the window at this baseline"
    else:
        limiting = "; ".join(r.name for r in cr.limiting) or "–"
        parts = []
        for r in cr.limiting:
            text = f"{r.name}: {_measured(r)} against {r.limit_text}"
            if cr.above_capacity is not None:
                text += f" at {cr.above_capacity:.0f} W (fails)"
            passing = _by_name(cr.at_capacity, r.name) if cr.capacity > 0 else None
            if passing is not None:
                text += f", {_measured(passing)} against {passing.limit_text} at {cr.capacity:.0f} W (passes)"
            parts.append(text)
        detail = "; ".join(parts) or "–"
    if sec.capacity is None:
        tested = "not tested"
    elif cr.capacity > 0 and k is not None:
        tested = "the capacity before reduction"
    elif cr.capacity > 0:
        tested = "the capacity"
    else:
        tested = "the smallest capacity tried (it fails)"
    return Capacity(w, pct, before, k, limiting, detail, tested)


def capacity_sentence(c: Capacity) -> str:
    """'14439 W (6.16 % of rated), the reduction factor K_red = 0.9476 applied to 15238 W
    before reduction'."""
    text = f"{c.w:.0f} W ({c.pct:.2f} % of rated)"
    if c.reduction_factor is not None:
        text += (
            f", the reduction factor K_red = {c.reduction_factor:.4f} applied to "
            f"{c.before_reduction_w:.0f} W before reduction"
        )
    return text


def margins_markdown(s: Section) -> list:
    """The margins table (closest first) and the readings of the rules, as Markdown lines."""
    out = []
    if s.margins:
        out += [
            "",
            "Margins at the capacity tested (distance inside each limit; relative to the limit, the Nyquist "
            "distance's to the radius 0.43, the window's to the rated power; negative: outside):",
            "",
            "| Limit | Margin | Relative |",
            "|---|---|---|",
        ]
        for m in s.margins:
            out.append(f"| {_cell(m.name)} | {m.distance:.6g} {_cell(m.unit)} | {m.relative:+.2%} |")
    if s.readings:
        out += [
            "",
            "Readings of the rules where they leave a choice (ours marked *; the verdict uses ours):",
            "",
            "| Choice | Requirement | Measured | Limit | Status |",
            "|---|---|---|---|---|",
        ]
        for i in s.readings:
            r = i.requirement
            status = {PASS: "pass", FAIL: "**FAIL**", UNSURE: "unsure"}[r.status]
            if r.status == FAIL and s.use_reduction and r.k_red:
                status = "**FAIL** without reduction; passes with K_red"
            out.append(
                f"| {_cell(i.choice)}{' *' if i.ours else ''} | {_cell(r.name)} | {_measured(r)} | "
                f"{_cell(r.limit_text)} | {status} |"
            )
    return out


def robust_text(s: Section) -> str:
    """'robust' when every reading of the rules passes (a reduction factor covering as in the
    verdict), else 'on an edge: <the readings that fail>'; '–' without readings."""
    if not s.readings:
        return "–"
    bad = [i for i in s.readings if i.requirement.status == FAIL and not (s.use_reduction and i.requirement.k_red)]
    if not bad:
        return "robust"
    return "on an edge: " + "; ".join(f"{i.requirement.name} fails with {i.choice}" for i in bad)


def unsure_rules(sections: Sequence[Section]) -> list:
    seen, out = set(), []
    for s in sections:
        for r in s.results:
            if r.status == UNSURE and r.name not in seen:
                seen.add(r.name)
                out.append(r)
    return out


def to_markdown(sections: Sequence[Section], title: str, rated_power: float, notes: Sequence[str] = ()) -> str:
    """The report as Markdown: the disclaimer, per test the capacity (W, % of rated; after the
    reduction factor where one applies) and the limiting requirement, a table (measured vs
    limit, status, K_red) at the capacity tested, then the unsure rules."""
    out = [f"# {title}", "", f"**{DISCLAIMER}**", "", f"Rated power of the assessed unit: {rated_power:.6g} W.", ""]
    for s in sections:
        out += [f"## {s.name}", ""]
        c = capacity(s, rated_power)
        if c is not None:
            out += [f"**Capacity: {capacity_sentence(c)}.** Limiting requirement: {c.detail}.", ""]
            if s.readings and c.w > 0:
                out += [f"Under every reading of the rules: {robust_text(s)}.", ""]
        if s.capacity is not None:
            where = f", {c.tested}" if c is not None else ""
            out += [f"Requirements at {s.capacity:.0f} W ({100 * s.capacity / rated_power:.2f} % of rated){where}:", ""]
        if s.results:
            out += [
                "| Requirement | Measured | Limit | Status | K_red (range) | Source, note |",
                "|---|---|---|---|---|---|",
            ]
        for r in s.results:
            k = "–" if r.k_red is None else f"{r.k_red:.4f}"
            if r.k_range:
                k += f" ({r.k_range[0]:g}–{r.k_range[1]:g})"
            st = {PASS: "pass", FAIL: "**FAIL**", UNSURE: "unsure (informative)"}[r.status]
            if r.status == FAIL and s.use_reduction and r.k_red:
                st = "**FAIL** without reduction; passes with K_red"
            cells = [r.name, _measured(r), r.limit_text, st, k, r.source + ("; " + r.note if r.note else "")]
            out.append("| " + " | ".join(_cell(x) for x in cells) + " |")
        out += margins_markdown(s)
        s_notes = list(s.notes) + (["plots: " + ", ".join(f"`{p}`" for p in s.plots)] if s.plots else [])
        out += [""] + [f"- {n}" for n in s_notes] + ([""] if s_notes else [])
    uns = unsure_rules(sections)
    out += ["## Unsure rules (informative, not pass/fail)", ""]
    out += [f"- {r.name}: {r.note or r.source}" for r in uns] or ["- none"]
    out += [""] + [f"- {n}" for n in notes]
    return "\n".join(out) + "\n"


#: The per-test CSV: one row per requirement; the unit of `measured` is in `unit`, that of
#: `low`/`high` in `limit unit`; every capacity in W (the capacity after reduction where one
#: applies; `capacity before reduction [W]` only then).
_COLUMNS = [
    "test",
    "requirement",
    "measured [see unit]",
    "unit",
    "limit",
    "low [see limit unit]",
    "high [see limit unit]",
    "limit unit",
    "status",
    "K_red [1]",
    "K_red min [1]",
    "K_red max [1]",
    "source",
    "note",
    "tested capacity [W]",
    "capacity [W]",
    "capacity [% of rated]",
    "capacity before reduction [W]",
    "reduction factor [1]",
    "limiting requirement",
]


def _rows(sections, rated_power):
    for s in sections:
        c = capacity(s, rated_power)
        figures = (
            [None] * 5
            if c is None
            else [
                f"{c.w:.0f}",
                f"{c.pct:.2f}",
                None if c.before_reduction_w is None else f"{c.before_reduction_w:.0f}",
                None if c.reduction_factor is None else f"{c.reduction_factor:.6g}",
                c.limiting,
            ]
        )
        for r in s.results:
            yield dict(
                zip(
                    _COLUMNS,
                    [
                        s.name,
                        r.name,
                        r.measured,
                        r.unit,
                        r.limit_text,
                        r.low,
                        r.high,
                        r.limit_unit,
                        r.status,
                        r.k_red,
                        r.k_range[0] if r.k_range else None,
                        r.k_range[1] if r.k_range else None,
                        r.source,
                        r.note,
                        None if s.capacity is None else f"{s.capacity:.0f}",
                        *figures,
                    ],
                )
            )


def write_csv(path, sections: Sequence[Section], rated_power: float) -> Path:
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=_COLUMNS)
        w.writeheader()
        for row in _rows(sections, rated_power):
            w.writerow({k: "" if v is None else v for k, v in row.items()})
    return path


def _number(x: float, digits: int) -> str:
    """A whole number as such (capacities in whole watts, the same figure as every file), any
    other to `digits` significant digits."""
    return f"{x:.0f}" if x.is_integer() else f"{x:.{digits}g}"


def write_rows(stem, rows: Sequence[dict], leave_out: Sequence[str] = (), digits: int = 6) -> None:
    """<stem>.json with every row whole, and <stem>.csv with its columns but `leave_out` (lists
    and free text): whole numbers whole, others to `digits` significant digits, None as an
    empty cell."""
    stem = Path(stem)
    stem.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")
    keys = [k for k in rows[0] if k not in leave_out]
    with stem.with_suffix(".csv").open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        for row in rows:
            w.writerow(
                [
                    "" if row[k] is None else _number(row[k], digits) if isinstance(row[k], float) else row[k]
                    for k in keys
                ]
            )


def _finite(x):
    """JSON has no inf/NaN: non-finite numbers become null (e.g. a never-reached activation)."""
    if isinstance(x, float) and not np.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


def write_json(path, sections: Sequence[Section], title: str, rated_power: float) -> Path:
    doc = {
        "title": title,
        "statement": DISCLAIMER,
        "rated_power_W": rated_power,
        "tests": [],
        "unsure_rules": [r.name for r in unsure_rules(sections)],
    }
    for s in sections:
        c = capacity(s, rated_power)
        entry = {"name": s.name, "tested_capacity_W": None if s.capacity is None else float(round(s.capacity))}
        if c is not None:
            entry.update(
                {
                    "capacity_W": c.w,
                    "capacity_pct_rated": c.pct,
                    "capacity_before_reduction_W": c.before_reduction_w,
                    "reduction_factor": c.reduction_factor,
                    "tested_at": c.tested,
                    "limiting_requirement": c.limiting,
                    "limiting_detail": c.detail,
                }
            )
        entry.update({"notes": list(s.notes), "plots": list(s.plots), "requirements": [r.to_dict() for r in s.results]})
        entry["margins"] = [
            {"limit": m.name, "margin": m.distance, "unit": m.unit, "relative": m.relative} for m in s.margins
        ]
        entry["readings"] = [{"choice": i.choice, "ours": i.ours, **i.requirement.to_dict()} for i in s.readings]
        entry["robust"] = robust_text(s)
        doc["tests"].append(entry)
    Path(path).write_text(json.dumps(_finite(doc), indent=2, ensure_ascii=False, allow_nan=False), encoding="utf-8")
    return Path(path)


def write_report(
    out_dir, stem: str, sections: Sequence[Section], title: str, rated_power: float, notes: Sequence[str] = ()
) -> dict:
    """Write <stem>.md, .csv, .json into out_dir; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md = out / f"{stem}.md"
    md.write_text(to_markdown(sections, title, rated_power, notes), encoding="utf-8")
    return {
        "md": md,
        "csv": write_csv(out / f"{stem}.csv", sections, rated_power),
        "json": write_json(out / f"{stem}.json", sections, title, rated_power),
    }


# ---------------------------------------------------------------- plots


def _pyplot():
    """matplotlib.pyplot on the Agg backend, imported at the first plot (a second of import that
    a report without plots, a usage error or a worker process does not pay)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _scale(c):
    return (1e6, "MW") if abs(c) >= 1e6 else (1e3, "kW") if abs(c) >= 1e3 else (1.0, "W")


def _limits(ax, signal: TestSignal, trace: Trace, C, k):
    """Draw the limits of the test on the power axis (values in units of k)."""
    m, t, d = signal.marks, trace.t, trace.dp_up

    def band(a, b, lo, hi, lab):
        ax.fill_between([a, b], lo / k, hi / k, color="tab:green", alpha=0.25, label=lab)

    kind, s = signal.kind, signal.direction
    if kind == "fcr_n_steps":
        base = 0.5 * (mean(t, d, *m["ss0"]) + mean(t, d, *m["ss3"]))
        band(*m["ss1"], base + 0.95 * C, base + 1.2 * C, "Req. 1 band")
        band(*m["ss2"], base - 1.2 * C, base - 0.95 * C, None)
    elif kind in ("fcr_d_ramp", "static_fcr_d_ramp"):
        hi = 1.2 if kind == "fcr_d_ramp" else 1.1
        a, b = m["ss3"] if kind == "fcr_d_ramp" else m["ss1"]
        ref = mean(t, d, *(m["ss4"] if kind == "fcr_d_ramp" else m["ss0"]))
        lo_, hi_ = sorted([ref + s * 0.95 * C, ref + s * hi * C])
        band(a, b, lo_, hi_, "Req. 1 band")
        t0 = m["t0"]
        r5 = mean(t, d, *(m["ref5"] if kind == "fcr_d_ramp" else m["ref1"]))
        ax.plot([t0 + 7.5], [(r5 + s * 0.86 * C) / k], "v", color="tab:red", label="Req. 2: 0.86·C at t0 + 7.5 s")
        ax.axvline(t0 + 7.5, color="tab:red", lw=0.6, ls=":")
        sel = (t >= t0) & (t <= t0 + 7.5)
        ax.fill_between(t[sel], r5 / k, d[sel] / k, color="tab:red", alpha=0.15, label="Req. 3: E(0-7.5 s)")
        t_end = m["t_ramp6"] if kind == "fcr_d_ramp" else m["t_ramp2"]
        ax.hlines(
            at(t, d, t0 + 7.5) / k,
            t0 + 7.5,
            t_end,
            color="tab:red",
            lw=0.6,
            ls="--",
            label="no fall below ΔP(t0 + 7.5 s)",
        )
        if kind == "fcr_d_ramp":
            tn = m["t_nadir"]
            r1 = mean(t, d, *m["ref1"])
            thr = min(abs(at(t, s * (d - r1), tn)), 0.5 * C)
            ax.hlines(
                (r1 + s * thr) / k,
                tn,
                tn + m["deactivation_window"],
                color="tab:purple",
                lw=0.8,
                label="Req. 4 threshold",
            )
            ax.axvline(tn, color="tab:purple", lw=0.6, ls=":")
            sel = (t >= tn) & (t <= tn + m["deactivation_window"])
            ax.fill_between(
                t[sel], (r1 + s * thr) / k, d[sel] / k, color="tab:purple", alpha=0.15, label="Req. 4 integrand"
            )
        else:
            ax.axhline((ref + s * 1.2 * C) / k, color="tab:red", lw=0.6, ls="--", label="Req. 5a: 1.2·C")
    elif kind in ("ce_fcr_steps", "frr_step", "ffr_step"):
        steps = (
            m["steps"]
            if kind == "ce_fcr_steps"
            else [(m["t_step"], s, m["t_end"])]
            if kind == "frr_step"
            else [(m["t_trigger"], UP, m["t_return"])]
        )
        fat = m["fat"]
        for t_on, sd, t_end in steps:
            ax.hlines(
                sd * C / k,
                t_on + fat,
                t_end,
                color="tab:red",
                lw=1.0,
                label=f"100 % from +{fat:g} s" if t_on == steps[0][0] else None,
            )
            ax.axvline(t_on + fat, color="tab:red", lw=0.6, ls=":")


def _verdict(fig, annotation: Optional[str], failing: bool, width: int = 150) -> float:
    """The binding requirement as a text box at the foot of `fig` (red edge if it fails at the
    capacity plotted, green if it passes); the fraction of the figure's height it takes."""
    if not annotation:
        return 0.0
    lines = [w for line in annotation.splitlines() for w in textwrap.wrap(line, width) or [""]]
    fig.text(
        0.01,
        0.005,
        "\n".join(lines),
        va="bottom",
        ha="left",
        fontsize=7,
        bbox=dict(boxstyle="round", facecolor="white", edgecolor="tab:red" if failing else "tab:green", linewidth=1.5),
    )
    return (len(lines) * 7 * 1.35 + 14) / 72 / fig.get_figheight()


def _metadata(title: Optional[str], annotation: Optional[str]) -> dict:
    """PNG text chunks: the title and the verdict, for readers of the file without the image."""
    meta = {"Title": title} if title else {}
    if annotation:
        meta["Description"] = annotation
    return meta


def plot_time_test(
    path,
    signal: TestSignal,
    trace: Trace,
    capacity: float,
    zoom: Optional[Sequence[tuple]] = None,
    title: Optional[str] = None,
    annotation: Optional[str] = None,
    failing: bool = False,
) -> Path:
    """Frequency (or request) on top, ΔP_up delivered and asked below with the limits; one more
    row per zoom window (t0, t1) [s] (default: ramp 5 and ramps 1-2 for FCR-D, ramp 1 for static
    FCR-D, the trigger for FFR). Asked = −reserveRequest if the trace carries it, else the static
    characteristic × C. `annotation` (the binding requirement, measured against its limit) is
    boxed at the foot, its edge red if `failing`, and kept as the PNG's Description."""
    k, unit = _scale(capacity)
    m = signal.marks
    if zoom is None:
        zoom = {
            "fcr_d_ramp": [(m.get("t0", 0) - 5, m.get("t0", 0) + 25), (25.0, 85.0)],
            "static_fcr_d_ramp": [(m.get("t0", 0) - 5, m.get("t0", 0) + 25)],
            "ffr_step": [(m.get("t_trigger", 0) - 2, m.get("t_trigger", 0) + 40)],
        }.get(signal.kind, [])
    n = 2 + len(zoom)
    plt = _pyplot()
    fig, axes = plt.subplots(n, 1, figsize=(10, 2.6 * n), squeeze=False)
    axes = axes[:, 0]
    if signal.f is not None:
        axes[0].plot(signal.t, signal.f, color="tab:blue")
        axes[0].set_ylabel("frequency [Hz]")
    else:
        axes[0].plot(signal.t, signal.request, color="tab:blue")
        axes[0].set_ylabel("request [p.u. of C]")
    characteristic = asked_response(signal) * capacity
    for ax, lim in zip(axes[1:], [None] + list(zoom)):
        ax.plot(signal.t, characteristic / k, color="0.5", ls="--", lw=1, label="static characteristic × C")
        if trace.reserve_request is not None:
            ax.plot(
                trace.t,
                -np.asarray(trace.reserve_request) / k,
                color="tab:orange",
                lw=1,
                label="asked (−reserveRequest)",
            )
        ax.plot(trace.t, trace.dp_up / k, color="k", lw=1.2, label="delivered ΔP_up")
        _limits(ax, signal, trace, capacity, k)
        ax.set_ylabel(f"ΔP_up [{unit}]")
        if lim is not None:
            ax.set_xlim(*lim)
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, loc="best")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(
        title or f"{signal.name}: C = {capacity / k:.4g} {unit}\n" + textwrap.fill(DISCLAIMER, 130), fontsize=8
    )
    fig.tight_layout(rect=(0, _verdict(fig, annotation, failing, 180), 1, 1))
    fig.savefig(path, dpi=110, metadata=_metadata(title, annotation))
    plt.close(fig)
    return Path(path)


def plot_nyquist(
    path,
    points: Sequence["fd.SinePoint"],
    product: str,
    title: Optional[str] = None,
    annotation: Optional[str] = None,
    failing: bool = False,
    dense: Optional["fd.DenseCurve"] = None,
) -> Path:
    """Nyquist curve of G0 = F·G (interpolated between the prescribed periods, those labelled)
    and, given the dense curve, G0 at every period tested (the unit's own curve), with the
    circles of radius 0.43 and 0.43·0.95 around −1; beside it Req. 9 (|G_c| against |1/D|,
    marked unsure). `annotation` as in plot_time_test."""
    _, g0, gp = fd.nyquist(points, product)
    plt = _pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5))
    a1.plot(g0.real, g0.imag, color="tab:green", lw=1.2, label="G0 = F·G (interpolated)")
    a1.plot(gp.real, gp.imag, "o", color="tab:green")
    if dense is not None:
        gd = np.array([p.F for p in dense.points]) * fd.grid_model(
            product, "stability", [p.omega for p in dense.points]
        )
        a1.plot(gd.real, gd.imag, ".-", color="tab:blue", lw=0.8, ms=3, label="G0 tested densely")
        k = int(np.argmin(dense.distance))
        a1.annotate(f"min {dense.minimum:.4f} at {dense.at_period:.4g} s", (gd[k].real, gd[k].imag), fontsize=7)
    for p, g in zip(points, gp):
        a1.annotate(f"{p.period:g} s", (g.real, g.imag), fontsize=7)
    for r, ls in ((fd.RADIUS, "--"), (fd.RADIUS * fd.MARGIN, "-")):
        a1.add_patch(plt.Circle((-1, 0), r, fill=False, color="tab:red", ls=ls, label=f"r = {r:.4g}"))
    a1.plot([-1], [0], "x", color="tab:red")
    a1.set_xlim(-3.0, 1.5)  # the neighbourhood of −1 (G0 starts far right at long periods)
    a1.set_ylim(-2.5, 1.5)
    a1.set_aspect("equal")
    a1.grid(alpha=0.3)
    a1.legend(fontsize=7)
    a1.set_xlabel("Re")
    a1.set_ylabel("Im")
    a1.set_title(f"{product} Req. 8 (stability)", fontsize=9)
    w = fd.dense_omega(points)
    g = fd.grid_model(product, "performance", w)
    gc = fd.K_MARGIN * np.abs(g / (1 + fd.interpolate_F(points, w) * g))
    a2.loglog(2 * np.pi / w, gc, color="tab:orange", label="K_margin·|G_c|")
    a2.loglog(2 * np.pi / w, np.abs(1 + 70j * w), color="tab:orange", ls="--", label="|1/D|, D = 1/(70 s + 1)")
    a2.set_xlabel("period [s]")
    a2.grid(alpha=0.3, which="both")
    a2.legend(fontsize=7)
    a2.set_title("Req. 9 (UNSURE: D(s) not confirmed)", fontsize=9)
    fig.suptitle(title or textwrap.fill(DISCLAIMER, 130), fontsize=8)
    fig.tight_layout(rect=(0, _verdict(fig, annotation, failing, 170), 1, 1))
    fig.savefig(path, dpi=110, metadata=_metadata(title, annotation))
    plt.close(fig)
    return Path(path)
