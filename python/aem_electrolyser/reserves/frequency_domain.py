"""Sine tests (NTR v1.1 §3.2-3.4.1): least-squares sine fit, the normalised transfer function
F(jω), Req. 8 (Nyquist stability), Req. 9 (performance, UNSURE) and Req. 10 (linearity).

F is taken from the frequency control error e = f_ref − f to the upward power ΔP_up [W]:

    F(jω) = (P̂/ê)·Δf_band/C,  |F| = (A_P/A_f)·Δf_band/C,  ∠F = ∠P̂ − ∠ê = (t_pk,e − t_pk,P)·2π/T

(P̂, ê: fitted phasors; Δf_band = 0.1 Hz FCR-N, 0.4 Hz FCR-D; negative phase = power lags),
times F_FME(jω) = 1/(1 + jω·T_FME) when the test frequency bypasses the measurement (§4.4; an FMU
input does: T_FME = 1 s, the TSOs' default). With this F the loop is 1 + F·G (eq. 10: G0 = F·G;
the box of Req. 8 writes −F·G, the same loop when F is taken from f itself instead of e).

Grid model (eq. 11): G(jω) = (ΔP_FCR-X/Δf_FCR-X)·(f0/S_n)/(2H·jω + K_f·f0) [p.u.] (Table 7).
Between tested periods F is interpolated with log|F| and the unwrapped phase linear in ω (exact
for a constant gain with a pure delay); G is exact; no extrapolation beyond the tested range.
"""

from __future__ import annotations

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


def stability(points: Sequence[SinePoint], product: str) -> Requirement:
    """Req. 8: min over the interpolated curve of |G0(jω) + 1| ≥ 0.43·0.95, and the curve passes
    right of the circle (no crossing of the negative real axis left of −1 − r)."""
    _, g0, gp = nyquist(points, product)
    dist = np.abs(g0 + 1)
    r = RADIUS * MARGIN
    im = g0.imag
    k = np.nonzero(im[:-1] * im[1:] <= 0)[0]
    re_x = g0.real[k] - im[k] * (g0.real[k + 1] - g0.real[k]) / np.where(im[k + 1] != im[k], im[k + 1] - im[k], 1.0)
    left = bool(np.any(re_x < -1 - r))
    res = check(
        f"{product} Req. 8: Nyquist distance of G0 = F·G to −1",
        float(dist.min()),
        "",
        r,
        None,
        "(0.43 · 0.95)",
        source=f"{NTR} §3.2 Req. 8",
        note=f"min at tested points {np.abs(gp + 1).min():.4f}; nominal radius 0.43"
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


def evaluate_sine_set(points: Sequence[SinePoint], product: str) -> list:
    """Req. 10 for every period, Req. 8 over the interpolated Nyquist curve, Req. 9 (unsure)."""
    out = [linearity_requirement(p, product) for p in sorted(points, key=lambda p: p.period)]
    if len(points) >= 2:
        out += [stability(points, product), performance(points, product)]
    return out
