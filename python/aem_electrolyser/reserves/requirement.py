"""The result of one requirement, the power trace evaluators read, and small trace helpers.

Sign convention (NTR §3.4, for a load): the trace holds the hub's consumption P(t) [W] and its
baseline P_baseline(t) [W] (the consumption without activation: the power setpoint before any
reserve request). Upward regulation is less consumption:

    ΔP_up(t) = −(P(t) − P_baseline(t))   [W]

Evaluators turn this into the delivered response of the tested direction, ΔP_dir = s·ΔP_up with
s = +1 for upward (under-frequency) and s = −1 for downward tests, so every limit below reads
"positive = delivered in the asked direction".
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Optional, Sequence

import numpy as np

PASS, FAIL, UNSURE = "pass", "fail", "unsure"

#: Relative numerical tolerance of every comparison (of the capacity or of the limit): far
#: below any measurement accuracy, it only keeps exact band edges (e.g. −5.000 %) on the
#: passing side of floating-point rounding.
NUM_TOL = 1e-9


@dataclass
class Requirement:
    """One requirement evaluated on one trace.

    measured/unit: the value read from the trace; low/high with limit_unit: the allowed interval
    (None = open side); status: PASS/FAIL at the offered capacity (no reduction), UNSURE when the
    rule or its quantification could not be confirmed (informative, never pass/fail); k_red: the
    largest capacity reduction factor with which this requirement passes, within k_range (None if
    the rules allow none here or none in the range passes)."""

    name: str
    measured: float
    unit: str
    low: Optional[float]
    high: Optional[float]
    limit_unit: str
    status: str
    k_red: Optional[float] = None
    k_range: Optional[tuple] = None
    source: str = ""
    note: str = ""

    @property
    def limit_text(self) -> str:
        u = f" {self.limit_unit}" if self.limit_unit else ""
        if self.low is not None and self.high is not None:
            return f"[{_g(self.low)}, {_g(self.high)}]{u}"
        if self.low is not None:
            return f"≥ {_g(self.low)}{u}"
        if self.high is not None:
            return f"≤ {_g(self.high)}{u}"
        return "–"

    def to_dict(self) -> dict:
        d = asdict(self)
        d["limit"] = self.limit_text
        return d


def _g(x: float) -> str:
    return f"{x:.6g}"


def check(
    name, measured, unit, low, high, limit_unit, *, source, note="", k_red=None, k_range=None, unsure=False, scale=1.0
) -> Requirement:
    """A Requirement with status from low ≤ measured ≤ high (tolerance NUM_TOL·scale), or
    UNSURE when `unsure` (the status is then informative only)."""
    tol = NUM_TOL * max(abs(scale), 1e-300)
    ok = (low is None or measured >= low - tol) and (high is None or measured <= high + tol)
    status = UNSURE if unsure else (PASS if ok else FAIL)
    return Requirement(name, float(measured), unit, low, high, limit_unit, status, k_red, k_range, source, note)


@dataclass
class Trace:
    """A power trace on the time grid t [s]: consumption p [W], baseline [W] (scalar or array),
    optionally the frequency f [Hz] seen by the unit and the asked change of draw
    `reserve_request` [W] (the FMU output: negative = draw less)."""

    t: np.ndarray
    p: np.ndarray
    baseline: object = 0.0
    f: Optional[np.ndarray] = None
    reserve_request: Optional[np.ndarray] = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float)
        self.p = np.asarray(self.p, dtype=float)
        if self.t.shape != self.p.shape or self.t.ndim != 1:
            raise ValueError("t and p must be 1-D arrays of the same length")
        if np.any(np.diff(self.t) <= 0):
            raise ValueError("t must be strictly increasing")

    @property
    def dp_up(self) -> np.ndarray:
        """ΔP_up = −(P − P_baseline) [W]."""
        return -(self.p - np.broadcast_to(np.asarray(self.baseline, float), self.p.shape))


def at(t: np.ndarray, x: np.ndarray, when: float) -> float:
    """x(when) by linear interpolation between samples."""
    if when < t[0] - 1e-9 or when > t[-1] + 1e-9:
        raise ValueError(f"t = {when} s is outside the trace [{t[0]}, {t[-1]}] s")
    return float(np.interp(when, t, x))


def window(t: np.ndarray, x: np.ndarray, t0: float, t1: float) -> tuple:
    """(t, x) on [t0, t1], the ends interpolated (exact for piecewise-linear x)."""
    inner = (t > t0) & (t < t1)
    tt = np.concatenate(([t0], t[inner], [t1]))
    return tt, np.concatenate(([at(t, x, t0)], x[inner], [at(t, x, t1)]))


def samples(t, x, t0, t1) -> np.ndarray:
    """x at the samples t0 ≤ t < t1 (half-open: a sample at the instant t1 of a step may
    already belong to the next level); x(t0) interpolated if there are none."""
    eps = 1e-9 * max(1.0, abs(t1))
    sel = (t >= t0 - eps) & (t < t1 - eps)
    return x[sel] if sel.any() else np.array([at(t, x, t0)])


def mean(t, x, t0, t1) -> float:
    """Time mean of x over [t0, t1] (trapezoid)."""
    tt, xx = window(t, x, t0, t1)
    return float(np.trapezoid(xx, tt) / (t1 - t0))


def integral(t, x, t0, t1) -> float:
    """∫ x dt over [t0, t1] [unit of x · s], trapezoid (exact for piecewise-linear x)."""
    tt, xx = window(t, x, t0, t1)
    return float(np.trapezoid(xx, tt))


def moving_mean(t, x, width: float) -> np.ndarray:
    """Trailing moving mean over `width` s at every sample (NTR eq. 13), trapezoid in time;
    the first `width` s use the available history."""
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * np.diff(t))))
    start = np.maximum(t - width, t[0])
    c0 = np.interp(start, t, cum)
    span = t - start
    out = np.empty_like(x, dtype=float)
    ok = span > 0
    out[ok] = (cum[ok] - c0[ok]) / span[ok]
    out[~ok] = x[~ok]
    return out


def worst(results: Sequence[Requirement]) -> str:
    """FAIL if any requirement fails, else PASS (UNSURE ones are informative)."""
    return FAIL if any(r.status == FAIL for r in results) else PASS
