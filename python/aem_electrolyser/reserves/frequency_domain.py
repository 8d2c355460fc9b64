"""Sine tests (NTR v1.1 §3.2-3.4.1): least-squares sine fit, the normalised transfer function
F(jω), Req. 8 (Nyquist stability), Req. 9 (performance, UNSURE) and Req. 10 (linearity).

F is taken from the frequency control error e = f_ref − f to the upward power ΔP_up [W]:

    F(jω) = (P̂/ê)·Δf_band/C,  |F| = (A_P/A_f)·Δf_band/C,  ∠F = ∠P̂ − ∠ê = (t_pk,e − t_pk,P)·2π/T

(P̂, ê: fitted phasors; Δf_band = 0.1 Hz FCR-N, 0.4 Hz FCR-D; negative phase = power lags),
times F_FME(jω) = 1/(1 + jω·T_FME) when the test frequency bypasses the measurement (§4.4; an FMU
input does: T_FME = 1 s, the TSOs' default). With this F the loop is 1 + F·G (eq. 10: G0 = F·G;
the box of Req. 8 writes −F·G, the same loop when F is taken from f itself instead of e).

Grid model (eq. 11): G(jω) = (ΔP_FCR-X/Δf_FCR-X)·(f0/S_n)/(2H·jω + K_f·f0) [p.u.] (NTR v1.1
§3.2 Table 7: the stability parameters S_n = 23 GW, H = 120 GWs/23 GW for Req. 8, the
performance ones S_n = 42 GW, H = 190 GWs/42 GW for Req. 9). The measurement filter
F_FME = 1/(1 + s·1 s) is the NTR's default for an internally injected test signal (§4.4).

Req. 8 is judged twice, and both must pass:
- at the tested periods, as the programme does: F between the prescribed periods interpolated
  with log|F| and the unwrapped phase linear in ω (exact for a constant gain with a pure delay;
  the NTR asks to "interpolate between the tested points" without naming a scheme, this is
  ours); G is exact; no extrapolation beyond the tested range;
- on the dense curve, the unit's own: sine tests at the test amplitude between the prescribed
  periods (DenseCurve), refined until the distance between neighbouring tested periods provably
  cannot dip more than DENSE_TOLERANCE below the smallest distance measured, under a bound on
  the curve's curvature in ln ω (CURVATURE_SAFETY times the largest second difference measured
  around each interval). At the test amplitude the unit is not linear (the rising-current limit
  clips the rising half of the current), so its curve between tested periods is not what an
  interpolation of the tested points says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from .requirement import Requirement, Trace, check
from .signals import BAND, TestSignal

NTR = "NTR v1.1"
RADIUS = 0.43
MARGIN = 0.95
K_MARGIN = 0.95
#: Table 7: (ΔP_FCR-X [W], Δf_FCR-X [Hz], S_n [W], H [s]); K_f = 0.01 p.u./Hz, f0 = 50 Hz.
GRID = {
    ("N", "stability"): (600e6, 0.1, 23000e6, 120000 / 23000),
    ("N", "performance"): (600e6, 0.1, 42000e6, 190000 / 42000),
    ("D", "stability"): (1450e6, 0.4, 23000e6, 120000 / 23000),
    ("D", "performance"): (1450e6, 0.4, 42000e6, 190000 / 42000),
}
K_F, F0 = 0.01, 50.0
#: Req. 9 reduction factor floors.
K_PERF_MIN = {"N": 0.9, "D": 0.75}


@dataclass
class SinePoint:
    """One sine test: period [s], F (normalised, complex), Req. 10 ratio, fitted amplitudes of
    the frequency [Hz] and of ΔP_up [W]."""

    period: float
    F: complex
    linearity: float
    amp_f: float
    amp_p: float

    @property
    def omega(self) -> float:
        return 2 * np.pi / self.period

    @property
    def gain(self) -> float:
        return abs(self.F)

    @property
    def phase_deg(self) -> float:
        return float(np.degrees(np.angle(self.F)))


def _family(product: str) -> str:
    return "N" if product == "FCR-N" else "D"


def fit_sine(t: np.ndarray, x: np.ndarray, period: float):
    """Least squares x ≈ c + a·cos ωt + b·sin ωt; returns (phasor X = b + j·a, i.e. x's sine part
    = |X|·sin(ωt + ∠X), offset c, fitted values)."""
    w = 2 * np.pi / period
    A = np.column_stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)])
    (c, a, b), *_ = np.linalg.lstsq(A, x, rcond=None)
    return complex(b, a), float(c), A @ np.array([c, a, b])


def sine_point(trace: Trace, capacity: float, signal: TestSignal, t_fme: Optional[float] = 1.0) -> SinePoint:
    """Fit f and ΔP_up over the marked stationary periods [t_a, t_b) → F(jω) and the Req. 10
    ratio RMS(ΔP − ΔP_est)/std(ΔP_est) (the fit includes an offset: an FCR-D sine at 49.7 Hz sits
    on 50 % activation)."""
    m, T = signal.marks, signal.marks["period"]
    a, b = m["eval"]
    dt = np.median(np.diff(trace.t))
    sel = (trace.t >= a - 1e-9 * T) & (trace.t < b - 0.5 * dt)
    tt = trace.t[sel]
    f = trace.f[sel] if trace.f is not None else np.interp(tt, signal.t, signal.f)
    xf, _, _ = fit_sine(tt, f, T)
    dp = trace.dp_up[sel]
    xp, _, est = fit_sine(tt, dp, T)
    F = (xp / -xf) * BAND[signal.product] / capacity
    if t_fme:
        F /= 1 + 1j * (2 * np.pi / T) * t_fme
    lin = float(np.sqrt(np.mean((dp - est) ** 2)) / np.std(est))
    return SinePoint(float(T), complex(F), lin, abs(xf), abs(xp))


def grid_model(product: str, which: str, omega) -> np.ndarray:
    """G(jω) of eq. 11 with the Table 7 parameters ('stability' or 'performance')."""
    dP, df, Sn, H = GRID[(_family(product), which)]
    return (dP / df) * (F0 / Sn) / (2 * H * 1j * np.asarray(omega) + K_F * F0)


def interpolate_F(points: Sequence[SinePoint], omega) -> np.ndarray:
    """F at ω inside the tested range: log|F| and unwrapped ∠F linear in ω."""
    pts = sorted(points, key=lambda p: p.omega)
    w = np.array([p.omega for p in pts])
    F = np.array([p.F for p in pts])
    ph = np.unwrap(np.angle(F))
    omega = np.asarray(omega, float)
    if omega.min() < w[0] * (1 - 1e-12) or omega.max() > w[-1] * (1 + 1e-12):
        raise ValueError("no extrapolation beyond the tested periods")
    return np.exp(np.interp(omega, w, np.log(np.abs(F))) + 1j * np.interp(omega, w, ph))


def dense_omega(points: Sequence[SinePoint], per_interval: int = 400) -> np.ndarray:
    w = np.sort([p.omega for p in points])
    parts = [np.linspace(w[i], w[i + 1], per_interval, endpoint=False) for i in range(len(w) - 1)]
    return np.concatenate(parts + [w[-1:]])


def nyquist(points: Sequence[SinePoint], product: str):
    """(ω dense, G0 = F·G_stab dense, G0 at the tested points)."""
    w = dense_omega(points)
    g0 = interpolate_F(points, w) * grid_model(product, "stability", w)
    wp = np.array([p.omega for p in points])
    return w, g0, np.array([p.F for p in points]) * grid_model(product, "stability", wp)


def passes_left(g0: np.ndarray, r: float) -> bool:
    """Whether the curve G0 (by ω) crosses the negative real axis left of −1 − r (encircles)."""
    im = g0.imag
    k = np.nonzero(im[:-1] * im[1:] <= 0)[0]
    re_x = g0.real[k] - im[k] * (g0.real[k + 1] - g0.real[k]) / np.where(im[k + 1] != im[k], im[k + 1] - im[k], 1.0)
    return bool(np.any(re_x < -1 - r))


def required_distance(margin: float = 0.0) -> float:
    """Req. 8's least distance to −1: 0.43·0.95, plus `margin` times the radius 0.43 (a stated
    margin the rules do not ask for, aem-prequalify --margin)."""
    return RADIUS * (MARGIN + margin)


def _limit_text(margin: float) -> str:
    return "(0.43 · 0.95)" if margin == 0 else f"(0.43 · (0.95 + {margin:g}))"


def stability(points: Sequence[SinePoint], product: str, margin: float = 0.0) -> Requirement:
    """Req. 8: min over the interpolated curve of |G0(jω) + 1| ≥ 0.43·0.95, and the curve passes
    right of the circle (no crossing of the negative real axis left of −1 − r)."""
    _, g0, gp = nyquist(points, product)
    dist = np.abs(g0 + 1)
    r = required_distance(margin)
    left = passes_left(g0, r)
    res = check(
        f"{product} Req. 8 at the tested periods: Nyquist distance of G0 = F·G to −1",
        float(dist.min()),
        "",
        r,
        None,
        _limit_text(margin),
        source=f"{NTR} §3.2 Req. 8",
        note=f"interpolated between the prescribed periods (log|F| and ∠F linear in ω); min at tested points "
        f"{np.abs(gp + 1).min():.4f}; nominal radius 0.43"
        + ("; FCR-N may ask for a 75 % margin exemption" if product == "FCR-N" else "")
        + ("; curve passes LEFT of −1 (encircles)" if left else ""),
    )
    if left:
        res.status = "fail"
    return res


def performance_ratio(points, product, k_red: float = 1.0) -> float:
    """max over ω of K_margin·|G_perf/(1 + (F/K_red)·G_perf)|·|D(jω)|, D(s) = 1/(70 s + 1)
    (Req. 9 holds when < 1)."""
    w = dense_omega(points)
    g = grid_model(product, "performance", w)
    gc = K_MARGIN * np.abs(g / (1 + interpolate_F(points, w) / k_red * g))
    return float(np.max(gc / np.abs(1 + 70j * w)))


def performance(points: Sequence[SinePoint], product: str) -> Requirement:
    """Req. 9, UNSURE: D(s) = 1/(70 s + 1) is read in a garbled transcription of the NTR and in
    third-party tools, not confirmed against the PDF or the TSO IT tool."""
    ratio = performance_ratio(points, product)
    kmin = K_PERF_MIN[_family(product)]
    k = None
    for kk in np.linspace(1.0, kmin, int(round((1 - kmin) / 0.001)) + 1):
        if performance_ratio(points, product, kk) < 1:
            k = float(kk)
            break
    return check(
        f"{product} Req. 9: performance max K_margin·|G_c|·|D| (D = 1/(70 s + 1))",
        ratio,
        "",
        None,
        1.0,
        "",
        source=f"{NTR} §3.3 Req. 9",
        unsure=True,
        k_red=k,
        k_range=(kmin, 1.0),
        note="UNSURE: the disturbance profile D(s) is not confirmed; informative only",
    )


def linearity_requirement(p: SinePoint, product: str) -> Requirement:
    """Req. 10: RMS(P − P_est)/std(P_est) < 1 for each tested period."""
    return check(
        f"{product} Req. 10: linearity at T = {p.period:g} s",
        p.linearity,
        "",
        None,
        1.0,
        "",
        source=f"{NTR} §3.4.1 Req. 10",
        note=f"|F| = {p.gain:.4f}, ∠F = {p.phase_deg:.2f}°"
        + ("; failing FCR-D entities are classed static FCR-D" if product != "FCR-N" else ""),
    )


def sine_linearity(trace: Trace, capacity: float, signal: TestSignal, t_fme: Optional[float] = 1.0) -> list:
    """Per-trace evaluation (Req. 10 of one period)."""
    return [linearity_requirement(sine_point(trace, capacity, signal, t_fme), signal.product)]


def evaluate_sine_set(
    points: Sequence[SinePoint], product: str, dense: Optional["DenseCurve"] = None, margin: float = 0.0
) -> list:
    """Req. 10 for every prescribed period, Req. 8 over the interpolated Nyquist curve of the
    prescribed periods and, given the dense curve, Req. 8 on it; Req. 9 (unsure) on the dense
    curve where there is one."""
    out = [linearity_requirement(p, product) for p in sorted(points, key=lambda p: p.period)]
    if len(points) >= 2:
        out.append(stability(points, product, margin))
        if dense is not None:
            out.append(dense_stability(dense, product, margin))
        out.append(performance(dense.points if dense is not None else points, product))
    return out


# --- the dense curve: sine tests between the prescribed periods --------------------------------

#: What the dense curve's minimum of |1 + G0| may miss between tested periods (absolute, in the
#: units of the Nyquist plane; 0.5 % of the required 0.43·0.95).
DENSE_TOLERANCE = 0.002
#: Before any refinement, neighbouring tested periods at most this ratio apart.
DENSE_START_RATIO = 1.25
#: No refinement below this ratio between neighbours (the bound is then reported as not reached).
DENSE_FINEST_RATIO = 1.002
#: The curvature bound: this factor times the largest second difference of |1 + G0| in ln ω
#: measured on the triples around an interval.
CURVATURE_SAFETY = 2.0
#: The most sine tests between the prescribed periods (a bound on the cost).
DENSE_MOST = 80


@dataclass
class DenseCurve:
    """The Nyquist distance measured at every tested period, prescribed and between.

    points: every sine test, by period; distance: |1 + F·G_stab| at each [1]; bound: the
    certified smallest distance over the whole tested range (the smallest measured, less what
    the curvature bound allows between neighbours) [1]; reached: whether the refinement met
    DENSE_TOLERANCE before its limits."""

    points: list
    distance: np.ndarray
    bound: float
    reached: bool

    @property
    def minimum(self) -> float:
        return float(self.distance.min())

    @property
    def at_period(self) -> float:
        return float(self.points[int(np.argmin(self.distance))].period)


def distances(points: Sequence[SinePoint], product: str) -> np.ndarray:
    """|1 + F(jω)·G_stab(jω)| at each tested point (no interpolation)."""
    w = np.array([p.omega for p in points])
    return np.abs(1 + np.array([p.F for p in points]) * grid_model(product, "stability", w))


def start_periods(prescribed: Sequence[float], ratio: float = DENSE_START_RATIO) -> list:
    """Periods between the prescribed ones, log-uniform, so that neighbours differ by at most
    `ratio` [s]."""
    ps = sorted(prescribed)
    out = []
    for a, b in zip(ps, ps[1:]):
        n = math.ceil(math.log(b / a) / math.log(ratio) - 1e-9)
        out += [a * (b / a) ** (k / n) for k in range(1, n)]
    return out


def interval_bounds(points: Sequence[SinePoint], product: str) -> tuple:
    """(the points by ω ascending, their distances, and per interval between neighbours the
    certified lower bound of the distance on it): with x = ln ω and |f''| ≤ M on the
    interval, f ≥ min(f_i, f_i+1) − M·h²/8; M = CURVATURE_SAFETY × the largest |second divided
    difference| of the triples that share the interval (its own two ends and one more)."""
    pts = sorted(points, key=lambda p: p.omega)
    x = np.log([p.omega for p in pts])
    d = distances(pts, product)
    n = len(pts)
    second = np.zeros(max(n - 2, 0))
    for k in range(n - 2):
        s1 = (d[k + 1] - d[k]) / (x[k + 1] - x[k])
        s2 = (d[k + 2] - d[k + 1]) / (x[k + 2] - x[k + 1])
        second[k] = 2.0 * abs(s2 - s1) / (x[k + 2] - x[k])
    bounds = np.empty(max(n - 1, 0))
    for i in range(n - 1):
        near = second[max(i - 1, 0) : min(i + 1, n - 2)]
        m = CURVATURE_SAFETY * (near.max() if near.size else 0.0)
        h = x[i + 1] - x[i]
        bounds[i] = min(d[i], d[i + 1]) - m * h * h / 8.0
    return pts, d, bounds


def refine_periods(
    points: Sequence[SinePoint], product: str, tolerance: float = DENSE_TOLERANCE, required: Optional[float] = None
) -> list:
    """The periods to test next [s]: the midpoint (in ln ω) of every interval whose certified
    bound lies more than `tolerance` below the smallest measured distance or, while every
    measured distance passes the `required` one, below that (so that the verdict is certain:
    a measured point fails, or every bound passes), unless its ends are already
    DENSE_FINEST_RATIO apart."""
    pts, d, bounds = interval_bounds(points, product)
    floor = d.min() - tolerance
    if required is not None and d.min() >= required:
        floor = max(floor, required)
    out = []
    for i, b in enumerate(bounds):
        lo, hi = pts[i].period, pts[i + 1].period
        if b < floor and max(lo, hi) / min(lo, hi) > DENSE_FINEST_RATIO:
            out.append(math.sqrt(lo * hi))
    return out


def dense_curve(
    points: Sequence[SinePoint], product: str, tolerance: float = DENSE_TOLERANCE, required: Optional[float] = None
) -> DenseCurve:
    """The DenseCurve of the tested points (call when refine_periods has nothing more to ask,
    or the budget is spent: `reached` says which)."""
    pts, d, bounds = interval_bounds(points, product)
    bound = float(min(d.min(), bounds.min() if bounds.size else d.min()))
    reached = not refine_periods(points, product, tolerance, required)
    return DenseCurve(pts, d, bound, reached)


def dense_stability(dense: DenseCurve, product: str, margin: float = 0.0) -> Requirement:
    """Req. 8 on the dense curve: its certified smallest distance ≥ 0.43·0.95 (+ margin·0.43)."""
    r = required_distance(margin)
    g0 = np.array([p.F for p in dense.points]) * grid_model(product, "stability", [p.omega for p in dense.points])
    left = passes_left(g0, r)
    res = check(
        f"{product} Req. 8 on the dense curve: Nyquist distance of G0 = F·G to −1",
        dense.bound,
        "",
        r,
        None,
        _limit_text(margin),
        source=f"{NTR} §3.2 Req. 8 (sine tests between the prescribed periods too)",
        note=f"smallest measured {dense.minimum:.4f} at T = {dense.at_period:.4g} s; certified ≥ {dense.bound:.4f} "
        f"between the {len(dense.points)} periods tested (tolerance {DENSE_TOLERANCE:g}"
        + ("" if dense.reached else ", not reached within the refinement's limits")
        + ")"
        + ("; curve passes LEFT of −1 (encircles)" if left else ""),
    )
    if left:
        res.status = "fail"
    return res
