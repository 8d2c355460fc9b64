"""Full-activation products: Continental FCR (SO GL Annex V), Nordic FFR (Fingrid), aFRR and
mFRR (standard products). ΔP = s·ΔP_up relative to the baseline [W] (s = +1 upward).

"Full activation" is ΔP ≥ (1 − tolerance)·C; no tolerance is stated in the sources, so the
default is 0 (only the numerical tolerance of `check`).
"""

from __future__ import annotations

import numpy as np

from .requirement import Trace, at, check, samples
from .signals import UP, TestSignal


def _full_and_held(tag, t, d, C, t_on, fat, t_end, tolerance, source):
    """ΔP(t_on + fat) ≥ (1 − tol)·C and min ΔP over [t_on + fat, t_end] ≥ (1 − tol)·C."""
    need = (1 - tolerance) * C
    w = samples(t, d, t_on + fat, t_end)
    return [
        check(
            f"{tag}: full activation within {fat:g} s",
            at(t, d, t_on + fat),
            "W",
            need,
            None,
            "W",
            source=source,
            scale=C,
            note=f"step at {t_on:g} s",
        ),
        check(
            f"{tag}: held until {t_end:g} s",
            float(w.min()),
            "W",
            need,
            None,
            "W",
            source=source,
            scale=C,
            note=f"lowest ΔP from {t_on + fat:g} s",
        ),
    ]


def ce_fcr(trace: Trace, capacity: float, signal: TestSignal, tolerance: float = 0.0) -> list:
    """Continental FCR (SO GL Annex V): 100 % of C within 30 s of each ±200 mHz step, held.
    The step profile is our assumption (the German double-hump profile is unsure)."""
    out = []
    for t_on, s, t_end in signal.marks["steps"]:
        out += _full_and_held(
            f"CE FCR {'up (49.8 Hz)' if s == UP else 'down (50.2 Hz)'}",
            trace.t,
            s * trace.dp_up,
            capacity,
            t_on,
            signal.marks["fat"],
            t_end,
            tolerance,
            "SO GL Annex V",
        )
    return out


def first_crossing(t, d, level, t_from) -> float:
    """First instant ≥ t_from where d reaches `level` (linear interpolation) [s]; inf if never."""
    i0 = np.searchsorted(t, t_from)
    idx = np.nonzero(d[i0:] >= level)[0]
    if idx.size == 0:
        return np.inf
    k = i0 + idx[0]
    if k == i0 or d[k - 1] >= level:
        return float(max(t[k], t_from))
    return float(t[k - 1] + (level - d[k - 1]) * (t[k] - t[k - 1]) / (d[k] - d[k - 1]))


def ffr(trace: Trace, capacity: float, signal: TestSignal, tolerance: float = 0.0) -> list:
    """FFR (Fingrid): full activation (ΔP_up ≥ C) at most 1.3/1.0/0.7 s after the crossing of
    49.7/49.6/49.5 Hz; then held ≥ 5 s from full activation if the deactivation is ≤ 20 %/s
    of C (largest 1-s drop from full activation to the end of the trace), else ≥ 30 s (a late
    activation fails the first requirement, not the support). Overshoot ≤ 20 % is UNSURE (not
    read in the Nordic FFR document)."""
    t, d, m, C = trace.t, trace.dp_up, signal.marks, capacity
    src = "Fingrid FFR"
    tt, fat = m["t_trigger"], m["fat"]
    need = (1 - tolerance) * C
    t_full = first_crossing(t, d, need - 1e-9 * C, tt)
    sel = (t >= min(t_full, tt + fat)) & (t + 1.0 <= t[-1])
    rate = float(np.max(d[sel] - np.interp(t[sel] + 1.0, t, d)) / C) if sel.any() else 0.0
    support = 5.0 if rate <= 0.2 + 1e-12 else 30.0
    start = t_full if np.isfinite(t_full) else tt + fat
    w = samples(t, d, start, min(start + support, t[-1]) + 1e-6)
    short = start + support > m["t_return"] + 1e-9
    return [
        check(f"FFR {m['trigger']} Hz: full activation time", t_full - tt, "s", None, fat, "s", source=src, scale=fat),
        check(
            f"FFR {m['trigger']} Hz: support for {support:g} s",
            float(w.min()),
            "W",
            need,
            None,
            "W",
            source=src,
            scale=C,
            note=f"largest deactivation rate {100 * rate:.1f} %/s of C (≤ 20 %/s → 5 s, "
            "else 30 s)" + ("; TEST TOO SHORT for this support" if short else ""),
        ),
        check(
            f"FFR {m['trigger']} Hz: overshoot ≤ 1.2·C",
            float(d.max()),
            "W",
            None,
            1.2 * C,
            "W",
            source="Nordic FFR technical requirements (not read)",
            unsure=True,
            scale=C,
            note="UNSURE: limit not confirmed; informative only",
        ),
    ]


def frr(trace: Trace, capacity: float, signal: TestSignal, tolerance: float = 0.0) -> list:
    """aFRR (full activation 5 min) / mFRR (12.5 min): the response to a reserve-power setpoint
    step reaches C by the full-activation time and is held until the request ends."""
    m = signal.marks
    tag = f"{signal.product} {'up' if signal.direction == UP else 'down'}"
    return _full_and_held(
        tag,
        trace.t,
        signal.direction * trace.dp_up,
        capacity,
        m["t_step"],
        m["fat"],
        m["t_end"],
        tolerance,
        "PICASSO (aFRR) / MARI (mFRR) standard products",
    )
