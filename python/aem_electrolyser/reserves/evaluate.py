"""Nordic FCR time-domain evaluators (NTR v1.1 §3.1, §3.4.2) and the dispatcher `evaluate`.

Every evaluator takes a Trace (consumption P and baseline [W]), the capacity C [W] offered
(= |ΔP_ss,theo|, the theoretical steady-state response to the full band: 0.1 Hz for FCR-N,
49.9→49.5 Hz for FCR-D) and the TestSignal that drove the run, and returns Requirements.
Delivered response in the tested direction: ΔP = s·ΔP_up = −s·(P − P_baseline), s = ±1.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from . import activation, frequency_domain
from .requirement import (
    FAIL,
    NUM_TOL,
    PASS,
    UNSURE,
    Requirement,
    Trace,
    at,
    check,
    integral,
    mean,
    moving_mean,
    samples,
    window,
)
from .signals import DOWN, UP, TestSignal

NTR = "NTR v1.1"
#: Capacity reduction factor ranges (NTR §3.1.1-3.1.3).
K_FCR_N = (0.9, 1.0)
K_FCR_D = (0.75, 1.0)
K_STATIC_DYN = (0.84, 1.0)


def k_steady(x: float, lo: float, hi: float, k_range) -> Optional[float]:
    """Largest K in k_range with lo ≤ (x − K)/K ≤ hi, x = ΔP_ss/|ΔP_ss,theo| (NTR Req. 1 with
    reduction factor): K ≤ x/(1 + lo) and K ≥ x/(1 + hi); None if no K in the range passes."""
    k = _snap(min(k_range[1], x / (1 + lo)), k_range)
    ok = k >= k_range[0] - NUM_TOL and k >= x / (1 + hi) - NUM_TOL
    return float(k) if ok else None


def _snap(k: float, k_range) -> float:
    """K within NUM_TOL of the top of its range is the top (rounding of exact band edges)."""
    return k_range[1] if k >= k_range[1] - NUM_TOL else k


def k_at_least(measured: float, needed_at_k1: float, k_range) -> Optional[float]:
    """Largest K in k_range with measured ≥ K·needed_at_k1 (Req. 2/3 with reduction factor)."""
    k = _snap(min(k_range[1], measured / needed_at_k1), k_range)
    return float(k) if k >= k_range[0] - NUM_TOL else None


def _steady(name, x, C, lo, hi, k_range, source, note=""):
    """Req. 1: (ΔP_ss − C)/C in [lo, hi] (delivered direction), in % of C."""
    k = k_steady(x / C, lo, hi, k_range) if k_range else None
    return check(
        name,
        100 * (x - C) / C,
        "%",
        100 * lo,
        100 * hi,
        "% of ΔP_ss,theo",
        source=source,
        k_red=k,
        k_range=k_range,
        scale=100,
        note=f"ΔP_ss = {x:.6g} W, ΔP_ss,theo = {C:.6g} W" + (f"; {note}" if note else ""),
    )


def _activation(tag, t, d, C, t0, k_range, source):
    """Req. 2: ΔP(t0 + 7.5 s) ≥ 0.86·C; Req. 3: ∫_{t0}^{t0+7.5 s} ΔP dt ≥ 3.2 s·C."""
    d75 = at(t, d, t0 + 7.5)
    e75 = integral(t, d, t0, t0 + 7.5)
    return [
        check(
            f"{tag} Req. 2: ΔP(t0 + 7.5 s) ≥ 0.86·ΔP_ss,theo",
            d75,
            "W",
            0.86 * C,
            None,
            "W",
            source=source,
            k_red=k_at_least(d75, 0.86 * C, k_range),
            k_range=k_range,
            scale=C,
            note=f"t0 = {t0:g} s; ΔP(7.5 s) = {100 * d75 / C:.2f} % of C",
        ),
        check(
            f"{tag} Req. 3: E(0-7.5 s) ≥ 3.2 s·ΔP_ss,theo",
            e75,
            "W·s",
            3.2 * C,
            None,
            "W·s",
            source=source,
            k_red=k_at_least(e75, 3.2 * C, k_range),
            k_range=k_range,
            scale=C,
            note=f"E = {e75 / C:.4f} s·C",
        ),
    ]


def _no_fall(tag, t, d, C, t0, t_end, osc_tol, source):
    """After t0 + 7.5 s the power must not fall below ΔP(t0 + 7.5 s) until t_end. A dip within
    osc_tol·C is reported UNSURE (NTR tolerates small well-damped oscillations; the tolerance is
    ours), a larger one FAIL."""
    d75 = at(t, d, t0 + 7.5)
    dip = float(min(samples(t, d, t0 + 7.5, t_end).min(), d75) - d75)
    r = check(
        f"{tag}: no fall below ΔP(t0 + 7.5 s) until {t_end:g} s",
        dip,
        "W",
        0.0,
        None,
        "W",
        source=source,
        scale=C,
        note=f"lowest ΔP − ΔP(7.5 s) = {100 * dip / C:.3f} % of C; dips up to "
        f"{100 * osc_tol:g} % of C reported unsure (our tolerance for 'small, "
        "well-damped oscillations')",
    )
    if r.status == FAIL and dip > -osc_tol * C:
        r.status = UNSURE
    return r


def deactivation_integral(t, d, t_nadir, threshold, span=40.0) -> float:
    """max over k in [t_nadir, t_nadir + span] of ∫_{t_nadir}^{k} (ΔP − threshold) dt [W·s],
    exact for piecewise-linear ΔP (the zero crossings of the integrand are inserted)."""
    tt, g = window(t, d - threshold, t_nadir, t_nadir + span)
    cross = np.nonzero(g[:-1] * g[1:] < 0)[0]
    tc = tt[cross] - g[cross] * (tt[cross + 1] - tt[cross]) / (g[cross + 1] - g[cross])
    tt = np.insert(tt, cross + 1, tc)
    g = np.insert(g, cross + 1, 0.0)
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(tt))))
    return float(cum.max())


def fcr_n_steps(trace: Trace, capacity: float, signal: TestSignal) -> list:
    """FCR-N step sequence (NTR §3.1.1): ΔP_ss,1 = P_ss,1 − ½(P_ss,0 + P_ss,3), ΔP_ss,2 likewise
    (P = ΔP_up, window means); Req. 1 up: (ΔP_ss,1 − C)/C ∈ [−5, +20] %, down:
    (−ΔP_ss,2 − C)/C ∈ [−5, +20] % (= NTR's −0.2 ≤ (ΔP_ss,2 + C)/C ≤ 0.05); K_red ≥ 0.9.
    Req. 12 (held while the deviation persists) is reported unsure (our quantification)."""
    t, d, m, C = trace.t, trace.dp_up, signal.marks, capacity
    P = [mean(t, d, *m[f"ss{k}"]) for k in range(4)]
    base = 0.5 * (P[0] + P[3])
    src = f"{NTR} §3.1.1 Req. 1"
    out = [
        _steady("FCR-N Req. 1 up (49.9 Hz)", P[1] - base, C, -0.05, 0.2, K_FCR_N, src),
        _steady("FCR-N Req. 1 down (50.1 Hz)", -(P[2] - base), C, -0.05, 0.2, K_FCR_N, src),
    ]
    mm = moving_mean(t, d, 10.0)
    for k, s in ((1, UP), (2, DOWN)):
        a, b = m[f"hold{k}"]
        w = samples(t, s * (mm - base), a + 60.0, b)
        out.append(
            check(
                f"FCR-N Req. 12 {'up' if s == UP else 'down'}: response held",
                100 * (w.min() - C) / C,
                "%",
                -5.0,
                None,
                "% of ΔP_ss,theo",
                source=f"{NTR} §3.1.1 Req. 12",
                unsure=True,
                scale=100,
                note="lowest 10-s mean from 60 s after the step to its end; the −5 % "
                "bound is our quantification of 'stays activated'",
            )
        )
    return out


def fcr_d_ramp(
    trace: Trace, capacity: float, signal: TestSignal, fcr_n_capacity: Optional[float] = None, osc_tol: float = 0.02
) -> list:
    """Dynamic FCR-D fast ramp test (NTR §3.1.2), ΔP in the tested direction:
    Req. 1: (P_ss,3 − P_ss,4 − C)/C ∈ [−5, +20] %, K_red,ss ∈ [0.75, 1];
    Req. 2/3 on ramp 5 (t0 = its start, ΔP relative to the 10-s mean before t0),
    K_red,dyn ∈ [0.75, 1]; no fall below ΔP(t0 + 7.5 s) until ramp 6;
    Req. 4: t_nadir = ramp-1 start + 4.4 s, ΔP relative to the 10-s mean before ramp 1,
    max_k ∫_{t_nadir}^{k} (ΔP − min(|ΔP(t_nadir)|, 0.5·C)) dt ≤ 2.5 s·C, k ≤ t_nadir + 40 s;
    Req. 1b (ramps 7-8, if present and fcr_n_capacity is given)."""
    t, m, C = trace.t, signal.marks, capacity
    d = signal.direction * trace.dp_up
    tag = signal.product
    src = f"{NTR} §3.1.2"
    x = mean(t, d, *m["ss3"]) - mean(t, d, *m["ss4"])
    out = [_steady(f"{tag} Req. 1: steady state P_ss,3 − P_ss,4", x, C, -0.05, 0.2, K_FCR_D, src + " Req. 1")]
    t0 = m["t0"]
    d5 = d - mean(t, d, *m["ref5"])
    out += _activation(tag, t, d5, C, t0, K_FCR_D, src)
    out.append(_no_fall(tag, t, d5, C, t0, m["t_ramp6"], osc_tol, src))
    d1 = d - mean(t, d, *m["ref1"])
    tn = m["t_nadir"]
    dn = at(t, d1, tn)
    thr = min(abs(dn), 0.5 * C)
    e = deactivation_integral(t, d1, tn, thr, m["deactivation_window"])
    out.append(
        check(
            f"{tag} Req. 4: deactivation energy after the nadir",
            e,
            "W·s",
            None,
            2.5 * C,
            "W·s",
            source=src + " Req. 4",
            scale=C,
            note=f"t_nadir = {tn:g} s, ΔP_nadir = {100 * dn / C:.2f} % of C, threshold "
            f"min(|ΔP_nadir|, 0.5·C) = {100 * thr / C:.2f} % of C, over "
            f"{m['deactivation_window']:g} s; max integral = {e / C:.4f} s·C",
        )
    )
    if "ss6" in m and fcr_n_capacity is not None:
        p6 = mean(t, d, *m["ss6"])
        for k in (7, 8):
            share = abs(m[f"df{k}"] - 0.1) / 0.4
            want = fcr_n_capacity + share * C
            out.append(
                _steady(
                    f"{tag} Req. 1b: combination, ramps 6 and {k}",
                    mean(t, d, *m[f"ss{k}"]) - p6,
                    want,
                    -0.05,
                    0.2,
                    None,
                    src + " Req. 1b",
                    note=f"expected C_FCR-N + {share:g}·C",
                )
            )
    return out


def static_fcr_d(trace: Trace, capacity: float, signal: TestSignal, osc_tol: float = 0.02, eps: float = 1e-6) -> list:
    """Static FCR-D ramp test (NTR §3.1.3): Req. 1 (P_ss,1 − P_ss,0 − C)/C ∈ [−5, +10] %;
    Req. 2/3 on ramp 1 with K_red,dyn ∈ [0.84, 1]; no fall below ΔP(t0 + 7.5 s) until ramp 2;
    Req. 5a max|ΔP| ≤ 1.2·C; Req. 5b |ΔP(t0 + 2.5 s)| > 0 (> eps·C); Req. 6 deactivated 15 min
    after 60 s back in band (|ΔP| ≤ 5 % C, our tolerance); Req. 7 ΔP(t − 10 s) − ΔP(t) ≤ 0.25·C
    and ΔP(t − 1 s) − ΔP(t) ≤ 0.2·C from ramp 2 on."""
    t, m, C = trace.t, signal.marks, capacity
    d = signal.direction * trace.dp_up
    tag, src = signal.product, f"{NTR} §3.1.3"
    x = mean(t, d, *m["ss1"]) - mean(t, d, *m["ss0"])
    out = [
        _steady(
            f"{tag} Req. 1: steady state P_ss,1 − P_ss,0",
            x,
            C,
            -0.05,
            0.10,
            None,
            src + " Req. 1",
            note="no K_red,ss is stated for static FCR-D",
        )
    ]
    t0, t2 = m["t0"], m["t_ramp2"]
    d0 = d - mean(t, d, *m["ref1"])
    out += _activation(tag, t, d0, C, t0, K_STATIC_DYN, src)
    out.append(_no_fall(tag, t, d0, C, t0, t2, osc_tol, src))
    w = samples(t, np.abs(d0), t0, t2)
    out.append(
        check(
            f"{tag} Req. 5a: overshoot |ΔP_max| ≤ 1.2·C",
            float(w.max()),
            "W",
            None,
            1.2 * C,
            "W",
            source=src + " Req. 5a",
            scale=C,
        )
    )
    d25 = at(t, d0, t0 + 2.5)
    out.append(
        check(
            f"{tag} Req. 5b: response begun at t0 + 2.5 s",
            abs(d25),
            "W",
            eps * C,
            None,
            "W",
            source=src + " Req. 5b",
            scale=0.0,
            note=f"|ΔP(t0 + 2.5 s)| > 0, numerical zero = {eps:g}·C",
        )
    )
    tr = m["t_ready"]
    if tr <= t[-1]:
        out.append(
            check(
                f"{tag} Req. 6: deactivated 15 min after 60 s in band",
                abs(at(t, d, tr)),
                "W",
                None,
                0.05 * C,
                "W",
                source=src + " Req. 6",
                scale=C,
                note=f"at t = {tr:g} s; 'deactivated' read as |ΔP| ≤ 5 % of C (our tolerance)",
            )
        )
    sel = t >= t2
    for lag, lim, lab in ((10.0, 0.25, "10-s window ≤ 2.5 %/s"), (1.0, 0.2, "1-s step ≤ 20 %")):
        ok = sel & (t - lag >= t[0])
        drop = float(np.max(np.interp(t[ok] - lag, t, d) - d[ok]))
        out.append(
            check(
                f"{tag} Req. 7: deactivation rate, {lab}",
                drop,
                "W",
                None,
                lim * C,
                "W",
                source=src + " Req. 7",
                scale=C,
                note=f"largest ΔP(t − {lag:g} s) − ΔP(t) from ramp 2 on",
            )
        )
    return out


def linearity(trace: Trace, capacity: float, signal: TestSignal) -> list:
    """Req. 11 (NTR §3.4.2): the 10-s moving mean of ΔP_up from 60 to 120 s after each step stays
    within −5 %/+10 % of C (delivered direction) around the expected C·|Δf|/Δf_band
    (FCR-N: Δf from 50 Hz, at exactly 50 Hz |ΔP| ≤ 10 %; FCR-D: from 49.9/50.1 Hz). The last
    FCR-D step back into the normal band is reported unsure (static units may be in their grace
    period)."""
    t, m, C, prod = trace.t, signal.marks, capacity, signal.product
    mm = moving_mean(t, trace.dp_up, 10.0)
    out, levels = [], m["levels"]
    for k in range(1, len(levels)):
        f = levels[k]
        a = m["step_starts"][k]
        w = samples(t, mm, a + 60.0, a + m["step_time"])
        if prod == "FCR-N":
            s = 1 if f < 50 else -1
            exp = (50.0 - f) / 0.1
        else:
            s = signal.direction
            exp = s * max(0.0, s * ((49.9 - f) if s == UP else (50.1 - f)) / 0.4)
        dev = s * (w - exp * C) / C if abs(f - 50.0) > 1e-9 else np.abs(w) / C
        lo, hi = (None, 0.10) if abs(f - 50.0) <= 1e-9 else (-0.05, 0.10)
        lo_margin = np.inf if lo is None else dev.min() - lo
        worst = dev.min() if lo_margin < hi - dev.max() else dev.max()
        last = prod != "FCR-N" and k == len(levels) - 1
        out.append(
            check(
                f"{prod} Req. 11: step to {f:.2f} Hz",
                100 * worst,
                "%",
                None if lo is None else 100 * lo,
                100 * hi,
                "% of C around expected",
                source=f"{NTR} §3.4.2 Req. 11",
                unsure=last,
                scale=100,
                note=f"expected {100 * exp:.1f} % of C"
                + ("; return into the normal band: informative" if last else ""),
            )
        )
    return out


def evaluate(trace: Trace, capacity: float, signal: TestSignal, **options) -> list:
    """Route one trace to the evaluator of its signal.kind. Options go to the evaluator
    (fcr_n_capacity, osc_tol, tolerance, t_fme, …)."""
    kind = signal.kind
    table = {
        "fcr_n_steps": fcr_n_steps,
        "fcr_d_ramp": fcr_d_ramp,
        "static_fcr_d_ramp": static_fcr_d,
        "linearity_steps": linearity,
        "ce_fcr_steps": activation.ce_fcr,
        "ffr_step": activation.ffr,
        "frr_step": activation.frr,
        "sine": frequency_domain.sine_linearity,
    }
    if kind not in table:
        raise ValueError(f"no evaluator for {kind}")
    return table[kind](trace, capacity, signal, **options)


__all__ = [
    "evaluate",
    "fcr_n_steps",
    "fcr_d_ramp",
    "static_fcr_d",
    "linearity",
    "deactivation_integral",
    "k_steady",
    "k_at_least",
    "PASS",
    "FAIL",
    "UNSURE",
    "Requirement",
]
