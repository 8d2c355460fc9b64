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

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import frequency_domain as fd  # noqa: E402
from .requirement import FAIL, PASS, UNSURE, Requirement, Trace, at, mean  # noqa: E402
from .signals import UP, TestSignal, asked_response  # noqa: E402

DISCLAIMER = ("This is a model-based assessment of the test programme (Nordic FCR technical "
              "requirements v1.1 of 28 March 2025 and test programme, Fingrid FFR, SO GL "
              "Annex V), not a prequalification approval.")


@dataclass
class Section:
    """One evaluated test: its name, requirements, the capacity offered [W] and, if searched,
    the bisection result (bisection.CapacityResult)."""

    name: str
    results: Sequence[Requirement]
    capacity: Optional[float] = None
    capacity_result: object = None
    notes: list = field(default_factory=list)


def _cell(x) -> str:
    """A Markdown table cell: pipes escaped (|G_c|, |ΔP_nadir| …)."""
    return str(x).replace("|", "\\|")


def _w(x: Optional[float]) -> str:
    return "–" if x is None else f"{x:.6g} W"


def _cap(sec: Section, rated: float) -> tuple:
    cr = sec.capacity_result
    if cr is None:
        return None, None, ""
    lim = "; ".join(r.name for r in cr.limiting) or ("none (upper bound passes)"
                                                   if cr.upper_bound_passes else "–")
    return cr.capacity, 100 * cr.capacity / rated, lim


def unsure_rules(sections: Sequence[Section]) -> list:
    seen, out = set(), []
    for s in sections:
        for r in s.results:
            if r.status == UNSURE and r.name not in seen:
                seen.add(r.name)
                out.append(r)
    return out


def to_markdown(sections: Sequence[Section], title: str, rated_power: float,
                notes: Sequence[str] = ()) -> str:
    """The report as Markdown: the disclaimer, per test a table (measured vs limit, status,
    K_red), the capacity (W, % of rated) and limiting requirement, then the unsure rules."""
    out = [f"# {title}", "", f"**{DISCLAIMER}**", "",
           f"Rated power of the assessed unit: {rated_power:.6g} W.", ""]
    for s in sections:
        out += [f"## {s.name}", ""]
        if s.capacity is not None:
            out += [f"Capacity offered: {_w(s.capacity)} ({100 * s.capacity / rated_power:.2f} % "
                    "of rated).", ""]
        c, pct, lim = _cap(s, rated_power)
        if c is not None:
            out += [f"**Largest passing capacity: {c:.6g} W ({pct:.2f} % of rated).** "
                    f"Limiting requirement: {lim}.", ""]
        out += ["| Requirement | Measured | Limit | Status | K_red (range) | Source, note |",
                "|---|---|---|---|---|---|"]
        for r in s.results:
            k = "–" if r.k_red is None else f"{r.k_red:.4f}"
            if r.k_range:
                k += f" ({r.k_range[0]:g}–{r.k_range[1]:g})"
            st = {PASS: "pass", FAIL: "**FAIL**", UNSURE: "unsure (informative)"}[r.status]
            cells = [r.name, f"{r.measured:.6g} {r.unit}".strip(), r.limit_text, st, k,
                     r.source + ("; " + r.note if r.note else "")]
            out.append("| " + " | ".join(_cell(c) for c in cells) + " |")
        out += [""] + [f"- {n}" for n in s.notes] + ([""] if s.notes else [])
    uns = unsure_rules(sections)
    out += ["## Unsure rules (informative, not pass/fail)", ""]
    out += [f"- {r.name}: {r.note or r.source}" for r in uns] or ["- none"]
    out += [""] + [f"- {n}" for n in notes]
    return "\n".join(out) + "\n"


_COLUMNS = ["test", "requirement", "measured", "unit", "limit", "low", "high", "limit_unit",
            "status", "k_red", "k_min", "k_max", "source", "note", "capacity_offered_W",
            "largest_capacity_W", "largest_capacity_pct_rated", "limiting_requirement"]


def _rows(sections, rated_power):
    for s in sections:
        c, pct, lim = _cap(s, rated_power)
        for r in s.results:
            yield {"test": s.name, "requirement": r.name, "measured": r.measured, "unit": r.unit,
                   "limit": r.limit_text, "low": r.low, "high": r.high,
                   "limit_unit": r.limit_unit, "status": r.status, "k_red": r.k_red,
                   "k_min": r.k_range[0] if r.k_range else None,
                   "k_max": r.k_range[1] if r.k_range else None, "source": r.source,
                   "note": r.note, "capacity_offered_W": s.capacity, "largest_capacity_W": c,
                   "largest_capacity_pct_rated": pct, "limiting_requirement": lim}


def write_csv(path, sections: Sequence[Section], rated_power: float) -> Path:
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=_COLUMNS)
        w.writeheader()
        for row in _rows(sections, rated_power):
            w.writerow({k: "" if v is None else v for k, v in row.items()})
    return path


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
    doc = {"title": title, "statement": DISCLAIMER, "rated_power_W": rated_power,
           "tests": [], "unsure_rules": [r.name for r in unsure_rules(sections)]}
    for s in sections:
        c, pct, lim = _cap(s, rated_power)
        doc["tests"].append({"name": s.name, "capacity_offered_W": s.capacity,
                             "largest_capacity_W": c, "largest_capacity_pct_rated": pct,
                             "limiting_requirement": lim, "notes": list(s.notes),
                             "requirements": [r.to_dict() for r in s.results]})
    Path(path).write_text(json.dumps(_finite(doc), indent=2, ensure_ascii=False, allow_nan=False),
                          encoding="utf-8")
    return Path(path)


def write_report(out_dir, stem: str, sections: Sequence[Section], title: str,
                 rated_power: float, notes: Sequence[str] = ()) -> dict:
    """Write <stem>.md, .csv, .json into out_dir; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md = out / f"{stem}.md"
    md.write_text(to_markdown(sections, title, rated_power, notes), encoding="utf-8")
    return {"md": md, "csv": write_csv(out / f"{stem}.csv", sections, rated_power),
            "json": write_json(out / f"{stem}.json", sections, title, rated_power)}


# ---------------------------------------------------------------- plots


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
        ax.plot([t0 + 7.5], [(r5 + s * 0.86 * C) / k], "v", color="tab:red",
                label="Req. 2: 0.86·C at t0 + 7.5 s")
        ax.axvline(t0 + 7.5, color="tab:red", lw=0.6, ls=":")
        sel = (t >= t0) & (t <= t0 + 7.5)
        ax.fill_between(t[sel], r5 / k, d[sel] / k, color="tab:red", alpha=0.15,
                        label="Req. 3: E(0-7.5 s)")
        t_end = m["t_ramp6"] if kind == "fcr_d_ramp" else m["t_ramp2"]
        ax.hlines(at(t, d, t0 + 7.5) / k, t0 + 7.5, t_end, color="tab:red", lw=0.6, ls="--",
                  label="no fall below ΔP(t0 + 7.5 s)")
        if kind == "fcr_d_ramp":
            tn = m["t_nadir"]
            r1 = mean(t, d, *m["ref1"])
            thr = min(abs(at(t, s * (d - r1), tn)), 0.5 * C)
            ax.hlines((r1 + s * thr) / k, tn, tn + m["deactivation_window"], color="tab:purple",
                      lw=0.8, label="Req. 4 threshold")
            ax.axvline(tn, color="tab:purple", lw=0.6, ls=":")
            sel = (t >= tn) & (t <= tn + m["deactivation_window"])
            ax.fill_between(t[sel], (r1 + s * thr) / k, d[sel] / k, color="tab:purple",
                            alpha=0.15, label="Req. 4 integrand")
        else:
            ax.axhline((ref + s * 1.2 * C) / k, color="tab:red", lw=0.6, ls="--",
                       label="Req. 5a: 1.2·C")
    elif kind in ("ce_fcr_steps", "frr_step", "ffr_step"):
        steps = (m["steps"] if kind == "ce_fcr_steps" else
                 [(m["t_step"], s, m["t_end"])] if kind == "frr_step" else
                 [(m["t_trigger"], UP, m["t_return"])])
        fat = m["fat"]
        for t_on, sd, t_end in steps:
            ax.hlines(sd * C / k, t_on + fat, t_end, color="tab:red", lw=1.0,
                      label=f"100 % from +{fat:g} s" if t_on == steps[0][0] else None)
            ax.axvline(t_on + fat, color="tab:red", lw=0.6, ls=":")


def plot_time_test(path, signal: TestSignal, trace: Trace, capacity: float,
                   zoom: Optional[Sequence[tuple]] = None, title: Optional[str] = None) -> Path:
    """Frequency (or request) on top, ΔP_up delivered and asked below with the limits; one more
    row per zoom window (t0, t1) [s] (default: ramp 5 and ramps 1-2 for FCR-D, ramp 1 for static
    FCR-D, the trigger for FFR). Asked = −reserveRequest if the trace carries it, else the static
    characteristic × C."""
    k, unit = _scale(capacity)
    m = signal.marks
    if zoom is None:
        zoom = {"fcr_d_ramp": [(m.get("t0", 0) - 5, m.get("t0", 0) + 25), (25.0, 85.0)],
                "static_fcr_d_ramp": [(m.get("t0", 0) - 5, m.get("t0", 0) + 25)],
                "ffr_step": [(m.get("t_trigger", 0) - 2, m.get("t_trigger", 0) + 40)]
                }.get(signal.kind, [])
    n = 2 + len(zoom)
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
        ax.plot(signal.t, characteristic / k, color="0.5", ls="--", lw=1,
                label="static characteristic × C")
        if trace.reserve_request is not None:
            ax.plot(trace.t, -np.asarray(trace.reserve_request) / k, color="tab:orange", lw=1,
                    label="asked (−reserveRequest)")
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
    axes[0].set_title(title or f"{signal.name}: C = {capacity / k:.4g} {unit}\n"
                      + textwrap.fill(DISCLAIMER, 130), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_nyquist(path, points: Sequence["fd.SinePoint"], product: str,
                 title: Optional[str] = None) -> Path:
    """Nyquist curve of G0 = F·G (interpolated between tested periods, the tested points
    labelled) with the circles of radius 0.43 and 0.43·0.95 around −1; beside it Req. 9
    (|G_c| against |1/D|, marked unsure)."""
    _, g0, gp = fd.nyquist(points, product)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5))
    a1.plot(g0.real, g0.imag, color="tab:green", lw=1.2, label="G0 = F·G (interpolated)")
    a1.plot(gp.real, gp.imag, "o", color="tab:green")
    for p, g in zip(points, gp):
        a1.annotate(f"{p.period:g} s", (g.real, g.imag), fontsize=7)
    for r, ls in ((fd.RADIUS, "--"), (fd.RADIUS * fd.MARGIN, "-")):
        a1.add_patch(plt.Circle((-1, 0), r, fill=False, color="tab:red", ls=ls,
                                label=f"r = {r:.4g}"))
    a1.plot([-1], [0], "x", color="tab:red")
    a1.set_xlim(-3.0, 1.5)      # the neighbourhood of −1 (G0 starts far right at long periods)
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
    a2.loglog(2 * np.pi / w, np.abs(1 + 70j * w), color="tab:orange", ls="--",
              label="|1/D|, D = 1/(70 s + 1)")
    a2.set_xlabel("period [s]")
    a2.grid(alpha=0.3, which="both")
    a2.legend(fontsize=7)
    a2.set_title("Req. 9 (UNSURE: D(s) not confirmed)", fontsize=9)
    fig.suptitle(title or textwrap.fill(DISCLAIMER, 130), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
