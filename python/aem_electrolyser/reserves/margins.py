"""How far each verdict sits from its limit, and how it moves under the choices the rules leave
open.

A margin is the distance of a measured value inside its limit, in the limit's own unit
(negative: outside), and relative to the limit's scale: the limit's magnitude, or for the
Nyquist distance the nominal radius 0.43 (a margin of 0.05 is 5 % of the radius). Where a
reduction factor covers a failing requirement, its margin is K_red less the rules' floor. The
operating window's margin is its bound less the capacity tested [W], relative to the rated power.

The interpretations the rules leave open, each evaluated again on the same traces (no new
simulation):
- the steady-state window: the last 60 s of a hold (ours) or the last 120 s;
- the interpolation of F between the prescribed periods for Req. 8: log|F| and ∠F linear in ω
  (ours), linear in ln ω, Re F and Im F linear in ω, and a monotone cubic (PCHIP) of log|F|
  and ∠F in ln ω;
- the order of the frequency measurement's filter: first order 1/(1 + s·1 s) (the NTR's
  default, ours), or second order with the same 1 s of lag, 1/(1 + s·0.5 s)².
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional, Sequence

import numpy as np

from . import evaluate, frequency_domain as fd
from .requirement import FAIL, PASS, UNSURE, Requirement, check

#: The steady-state windows compared [s]: the last `n` s of each hold.
STEADY_WINDOWS = (60.0, 120.0)
#: The measurement filter: first order with T_FME = 1 s, and its second-order alternative.
FILTERS = {
    "first order 1/(1 + s·1 s)": lambda w: 1.0 / (1.0 + 1j * w),
    "second order 1/(1 + s·0.5 s)²": lambda w: 1.0 / (1.0 + 0.5j * w) ** 2,
}
OURS_FILTER = "first order 1/(1 + s·1 s)"


@dataclass(frozen=True)
class Margin:
    """One limit's margin: what, the distance inside it [unit] (negative: outside), and that
    distance relative to the limit's scale [1]."""

    name: str
    distance: float
    unit: str
    relative: float


def scale(r: Requirement) -> float:
    """The magnitude a relative margin of `r` is taken against."""
    if "Req. 8" in r.name:
        return fd.RADIUS
    limits = [abs(x) for x in (r.low, r.high) if x is not None]
    return max(max(limits, default=1.0), 1e-12)


def of_requirement(r: Requirement) -> Optional[Margin]:
    """The margin of a pass/fail requirement (None for an informative one or one without a
    limit); a failing one that a reduction factor covers gets K_red less its floor."""
    if r.status == UNSURE or (r.low is None and r.high is None):
        return None
    if r.status == FAIL and r.k_red and r.k_range:
        return Margin(
            f"{r.name}: K_red above its floor {r.k_range[0]:g}", r.k_red - r.k_range[0], "", r.k_red - r.k_range[0]
        )
    gaps = []
    if r.low is not None:
        gaps.append(r.measured - r.low)
    if r.high is not None:
        gaps.append(r.high - r.measured)
    d = min(gaps)
    if r.status == PASS and d == 0.0 and 0.0 in (r.low, r.high):
        # Met with equality by construction (nothing falls below where it stood: the lowest
        # power less itself): no distance to report.
        return None
    return Margin(r.name, d, r.limit_unit or r.unit, d / scale(r))


def window(capacity: float, upper: Optional[float], rated: float) -> Optional[Margin]:
    """The operating window's margin: its bound less the capacity tested [W]."""
    if upper is None or upper <= 0:
        return None
    return Margin("operating window", upper - capacity, "W", (upper - capacity) / rated)


def of_run(results: Sequence[Requirement], capacity: float, upper: Optional[float], rated: float) -> list:
    """Every margin at a tested capacity, the closest first."""
    out = [m for m in map(of_requirement, results) if m is not None]
    w = window(capacity, upper, rated)
    if w is not None:
        out.append(w)
    return sorted(out, key=lambda m: m.relative)


# --- interpretations --------------------------------------------------------------------------


@dataclass(frozen=True)
class Interpretation:
    """One requirement judged under one reading of the rules: the choice, the requirement
    (measured against its limit, status), and whether it is the reading the verdict uses."""

    choice: str
    requirement: Requirement
    ours: bool


def steady_windows(tests, capacity: float, seconds: float) -> list:
    """Req. 1 (and the other steady-state requirements) with every steady-state window ("ss…"
    marks) the last `seconds` of its hold instead of the last 60 s; [] where no test has one."""
    out = []
    for signal, trace in tests:
        marks = dict(signal.marks)
        changed = False
        for key, value in signal.marks.items():
            if key.startswith("ss") and isinstance(value, tuple) and len(value) == 2:
                t0, t1 = value
                hold = hold_start(signal, t1)
                marks[key] = (max(t1 - seconds, hold), t1)
                changed = True
        if not changed:
            continue
        again = evaluate.evaluate(trace, capacity, replace(signal, marks=marks))
        out += [r for r in again if "steady state" in r.name or "Req. 1 " in r.name]
    return out


def hold_start(signal, t1: float) -> float:
    """Where the frequency last changed before t1 [s]: a steady-state window never reaches
    back across the step it belongs to."""
    t, f = signal.t, signal.f
    if f is None:
        return float(t[0])
    before = np.nonzero((t < t1) & (np.abs(np.diff(f, prepend=f[0])) > 0))[0]
    return float(t[before[-1]]) if before.size else float(t[0])


def interpolated_distance(points: Sequence["fd.SinePoint"], product: str, scheme: str) -> float:
    """min |1 + F·G_stab| over the prescribed range, F interpolated by `scheme`."""
    pts = sorted(points, key=lambda p: p.omega)
    w = np.array([p.omega for p in pts])
    F = np.array([p.F for p in pts])
    dense = fd.dense_omega(pts)
    if scheme == "log|F|, ∠F linear in ω":
        Fi = fd.interpolate_F(pts, dense)
    elif scheme == "log|F|, ∠F linear in ln ω":
        ph = np.unwrap(np.angle(F))
        x, xi = np.log(w), np.log(dense)
        Fi = np.exp(np.interp(xi, x, np.log(np.abs(F))) + 1j * np.interp(xi, x, ph))
    elif scheme == "Re F, Im F linear in ω":
        Fi = np.interp(dense, w, F.real) + 1j * np.interp(dense, w, F.imag)
    elif scheme == "PCHIP of log|F|, ∠F in ln ω":
        from scipy.interpolate import PchipInterpolator

        ph = np.unwrap(np.angle(F))
        x, xi = np.log(w), np.log(dense)
        Fi = np.exp(PchipInterpolator(x, np.log(np.abs(F)))(xi) + 1j * PchipInterpolator(x, ph)(xi))
    else:
        raise ValueError(f"no interpolation scheme {scheme!r}")
    return float(np.abs(1 + Fi * fd.grid_model(product, "stability", dense)).min())


SCHEMES = (
    "log|F|, ∠F linear in ω",
    "log|F|, ∠F linear in ln ω",
    "Re F, Im F linear in ω",
    "PCHIP of log|F|, ∠F in ln ω",
)


def refiltered(points: Sequence["fd.SinePoint"], name: str) -> list:
    """The sine points with F measured through the filter `name` instead of ours."""
    ours, other = FILTERS[OURS_FILTER], FILTERS[name]
    return [replace(p, F=complex(p.F / ours(p.omega) * other(p.omega))) for p in points]


def stability_readings(points, dense: Optional["fd.DenseCurve"], product: str, required: float) -> list:
    """Req. 8 under every interpolation scheme (prescribed periods) and both filter orders
    (prescribed periods, ours interpolated, and the dense curve)."""
    out = []
    for scheme in SCHEMES:
        d = interpolated_distance(points, product, scheme)
        out.append(
            Interpretation(
                f"interpolation: {scheme}",
                _stability(f"{product} Req. 8 at the tested periods", d, required),
                scheme == SCHEMES[0],
            )
        )
    for name in FILTERS:
        if name == OURS_FILTER:
            continue
        again = refiltered(points, name)
        out.append(
            Interpretation(
                f"measurement filter: {name}",
                _stability(
                    f"{product} Req. 8 at the tested periods",
                    interpolated_distance(again, product, SCHEMES[0]),
                    required,
                ),
                False,
            )
        )
        if dense is not None:
            curve = fd.dense_curve(refiltered(dense.points, name), product)
            out.append(
                Interpretation(
                    f"measurement filter: {name}",
                    _stability(f"{product} Req. 8 on the dense curve", curve.bound, required),
                    False,
                )
            )
    return out


def _stability(name: str, distance: float, required: float) -> Requirement:
    return check(name, distance, "", required, None, "", source=f"{fd.NTR} §3.2 Req. 8")


def readings(run, product, capacity: float, required: float) -> list:
    """Every interpretation of a run: the steady-state windows and, with sine tests, Req. 8's."""
    out = []
    for seconds in STEADY_WINDOWS:
        for r in steady_windows(run.tests, capacity, seconds):
            out.append(Interpretation(f"steady state: the last {seconds:g} s of each hold", r, seconds == 60.0))
    if len(run.points) >= 2:
        out += stability_readings(run.points, run.dense, product.sine, required)
    return out


def robust(interpretations: Sequence[Interpretation], use_reduction: bool) -> bool:
    """Whether the verdict holds under every reading (a reduction factor covers as in the
    verdict itself)."""
    return all(i.requirement.status != FAIL or (use_reduction and i.requirement.k_red) for i in interpretations)


def status_text(r: Requirement) -> str:
    return {PASS: "pass", FAIL: "FAIL", UNSURE: "unsure"}[r.status]


__all__ = [
    "Margin",
    "Interpretation",
    "of_requirement",
    "of_run",
    "window",
    "readings",
    "robust",
    "SCHEMES",
    "FILTERS",
    "STEADY_WINDOWS",
]
