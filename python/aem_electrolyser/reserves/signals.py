"""Test programmes as frequency signals f(t) [Hz] (or, for aFRR/mFRR, a reserve-power request)
sampled on a time grid t = k·dt [s], with the marks the evaluators read.

Piecewise-linear profiles are evaluated exactly at every grid point (a ramp between two
breakpoints is linear in t; a step takes its new value at its own instant). Sources:
NTR = Technical Requirements for FCR Provision in the Nordic Synchronous Area v1.1 (28 March 2025);
NTP = Test Program for Prequalification of FCR in the Nordic Synchronous Area (28 March 2025);
Fingrid FFR pages; SO GL (EU 2017/1485) Annex V; regelleistung.net, Elia (aFRR/mFRR).

Steady-state windows ("ss…" marks) are the last 60 s of each hold (15 s of the 60-s static
FCR-D hold), ending 1 s before a frequency STEP (the sample at a step instant may belong to
either level): the NTR does not state the averaging window, this is our choice.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import math

import numpy as np

UP, DOWN, BOTH = 1, -1, 0

#: NTR Table 6 / NTP Tables 4, 7, 10: period T [s] -> (stationary periods, recommended total).
SINE_PERIODS = {
    10: (5, 20),
    15: (5, 15),
    25: (5, 10),
    40: (5, 7),
    50: (5, 7),
    60: (5, 7),
    70: (5, 7),
    90: (5, 7),
    150: (3, 4),
    300: (2, 3),
}
#: Sine centre [Hz] and one-sided band Δf_band [Hz] per product (NTR §3.2, eq. 7).
SINE_CENTRE = {"FCR-N": 50.0, "FCR-D up": 49.7, "FCR-D down": 50.3}
BAND = {"FCR-N": 0.1, "FCR-D up": 0.4, "FCR-D down": 0.4, "CE FCR": 0.2}
#: Fingrid FFR: trigger frequency [Hz] -> longest full-activation time [s].
FFR_OPTIONS = {49.7: 1.3, 49.6: 1.0, 49.5: 0.7}
#: Full-activation times [s]: aFRR (PICASSO) 5 min, mFRR (MARI) 12.5 min.
FRR_FAT = {"aFRR": 300.0, "mFRR": 750.0}


@dataclass
class TestSignal:
    """One test: the grid t [s], the frequency f [Hz] (None for aFRR/mFRR), the reserve request
    [p.u. of the capacity, +1 = full upward = draw less] for aFRR/mFRR (None otherwise), the
    evaluation marks (instants [s], windows (t0, t1) [s]) and notes (assumptions)."""

    name: str
    kind: str
    product: str
    direction: int
    t: np.ndarray
    f: Optional[np.ndarray]
    marks: dict
    request: Optional[np.ndarray] = None
    notes: list = field(default_factory=list)
    source: str = ""


def grid(t_end: float, dt: float = 0.1) -> np.ndarray:
    """t = k·dt for k = 0…round(t_end/dt) [s]."""
    n = int(round(t_end / dt))
    if abs(n * dt - t_end) > 1e-9 * max(1.0, t_end):
        raise ValueError(f"t_end = {t_end} s is not a multiple of dt = {dt} s")
    return np.arange(n + 1) * dt


def piecewise(t: np.ndarray, points) -> np.ndarray:
    """Profile through breakpoints [(time, value), …] (times non-decreasing): linear between
    breakpoints, a repeated time is a step (the later value holds from that instant), held after
    the last breakpoint."""
    tp = np.array([p[0] for p in points], float)
    vp = np.array([p[1] for p in points], float)
    i = np.clip(np.searchsorted(tp, t, side="right") - 1, 0, len(tp) - 1)
    j = np.minimum(i + 1, len(tp) - 1)
    span = tp[j] - tp[i]
    w = np.where(span > 0, (t - tp[i]) / np.where(span > 0, span, 1.0), 0.0)
    return np.where(t < tp[0], vp[0], vp[i] + np.clip(w, 0.0, 1.0) * (vp[j] - vp[i]))


def _mirror(f: np.ndarray, direction: int) -> np.ndarray:
    """Downward tests mirror the upward frequencies about 50 Hz (NTR Table 4)."""
    return f if direction == UP else 100.0 - f


def _ramps(rows, f_start: float):
    """Breakpoints of ramps (start [s], rate [Hz/s], target [Hz]) at their stated rates."""
    pts, f_prev = [(0.0, f_start)], f_start
    for start, rate, target in rows:
        pts += [(start, f_prev), (start + abs(target - f_prev) / rate, target)]
        f_prev = target
    return pts


def fcr_n_steps(dt: float = 0.1, endurance: bool = False) -> TestSignal:
    """FCR-N step sequence (NTR §3.1.1 / NTP Table 3): 50.0 (0.5 min), 49.95 (0.5 min), 50.0
    (5 min, P0), 49.9 (5 or 15 min, P1), 50.1 (5 or 15 min, P2), 50.0 (5 min, P3)."""
    hold = 900.0 if endurance else 300.0
    s1, s2 = 360.0, 360.0 + hold
    s3 = s2 + hold
    pts = [
        (0, 50.0),
        (30, 50.0),
        (30, 49.95),
        (60, 49.95),
        (60, 50.0),
        (s1, 50.0),
        (s1, 49.9),
        (s2, 49.9),
        (s2, 50.1),
        (s3, 50.1),
        (s3, 50.0),
    ]
    end = s3 + 300.0
    t = grid(end, dt)
    marks = {
        "ss0": (s1 - 61, s1 - 1),
        "ss1": (s2 - 61, s2 - 1),
        "ss2": (s3 - 61, s3 - 1),
        "ss3": (end - 60, end),
        "hold1": (s1, s2),
        "hold2": (s2, s3),
        "steps": [s1, s2, s3],
    }
    return TestSignal(
        "FCR-N step sequence" + (" (endurance)" if endurance else ""),
        "fcr_n_steps",
        "FCR-N",
        BOTH,
        t,
        piecewise(t, pts),
        marks,
        source="NTR v1.1 §3.1.1, NTP Table 3",
    )


def fcr_d_ramp(direction: int = UP, dt: float = 0.1, combination: bool = False, endurance: bool = False) -> TestSignal:
    """Dynamic FCR-D fast ramp test (NTR Table 4 / NTP Tables 6, 9), ramps at their stated
    rates and targets (the table's rounded "ramp end" column is not used: for ramps 1, 7, 8 it
    does not match rate and target). With `combination` ramps 7-8 (FCR-N + FCR-D) are added;
    `endurance` holds ramp 3 for 900 s instead of 300 s (non-LER)."""
    sh = 600.0 if endurance else 0.0
    rows = [
        (30.0, 0.14, 49.45),
        (34.9, 0.09, 49.9),
        (90.0, 0.24, 49.5),
        (390.0 + sh, 0.24, 49.9),
        (690.0 + sh, 0.24, 49.0),
        (750.0 + sh, 0.24, 50.0),
    ]
    if combination:
        rows += [(1050.0 + sh, 0.24, 49.7), (1350.0 + sh, 0.24, 49.89)]
    end = (1650.0 if combination else 1050.0) + sh
    t = grid(end, dt)
    f = _mirror(piecewise(t, _ramps(rows, 49.9)), direction)
    r = {i + 1: row[0] for i, row in enumerate(rows)}
    marks = {
        "ramp_start": r,
        "t0": r[5],
        "t_ramp6": r[6],
        "t_nadir": r[1] + 4.4,
        "deactivation_window": 40.0,
        "ref1": (r[1] - 10, r[1]),
        "ref5": (r[5] - 10, r[5]),
        "ss3": (r[4] - 60, r[4]),
        "ss4": (r[5] - 60, r[5]),
    }
    if combination:
        marks.update(ss6=(r[7] - 60, r[7]), ss7=(r[8] - 60, r[8]), ss8=(end - 60, end), df7=0.3, df8=0.11)
    name = f"FCR-D {'up' if direction == UP else 'down'} fast ramp test"
    return TestSignal(
        name + (" with ramps 7-8" if combination else "") + (" (endurance)" if endurance else ""),
        "fcr_d_ramp",
        "FCR-D up" if direction == UP else "FCR-D down",
        direction,
        t,
        f,
        marks,
        notes=["ramp ends follow rate and target (NTR Table 4's rounded ramp-end column differs for ramps 1, 7, 8)"],
        source="NTR v1.1 §3.1.2 Table 4, NTP Tables 6/9",
    )


def static_fcr_d_ramp(direction: int = UP, dt: float = 0.1, endurance: Optional[str] = None) -> TestSignal:
    """Static FCR-D ramp test (NTR §3.1.3 Table 5, NTP Tables 12, 14): 49.9 Hz for 180 s, ramp
    at 0.24 Hz/s to 49.5 Hz held 60 s (900 s `endurance='non-LER'`, 1800 s 'LER'), ramp back to
    49.9 Hz held 1200 s."""
    hold = {None: 60.0, "non-LER": 900.0, "LER": 1800.0}[endurance]
    r2 = 180.0 + hold
    t = grid(r2 + 1200.0, dt)
    f = _mirror(piecewise(t, _ramps([(180.0, 0.24, 49.5), (r2, 0.24, 49.9)], 49.9)), direction)
    w = 15.0 if hold <= 60.0 else 60.0
    marks = {
        "t0": 180.0,
        "t_ramp2": r2,
        "ss0": (120.0, 180.0),
        "ss1": (r2 - w, r2),
        "ref1": (170.0, 180.0),
        "t_ready": r2 + 60.0 + 900.0,
    }
    return TestSignal(
        f"Static FCR-D {'up' if direction == UP else 'down'} ramp test"
        + (f" ({endurance} endurance)" if endurance else ""),
        "static_fcr_d_ramp",
        "static FCR-D up" if direction == UP else "static FCR-D down",
        direction,
        t,
        f,
        marks,
        source="NTR v1.1 §3.1.3 Table 5, NTP Tables 12/14",
    )


def linearity_steps(product: str = "FCR-D up", dt: float = 0.1, step_time: float = 120.0) -> TestSignal:
    """Linearity step sequences (NTR §3.4.2, NTP §3.3/4.3/6.2), each level held `step_time` s:
    FCR-N 50.00 → 49.90 → 50.10 → 50.00 in 20 mHz steps; FCR-D up 49.9 → 49.5 in 100 mHz steps,
    then 49.91 (down: mirrored, ending at 50.09)."""
    if product == "FCR-N":
        levels = [
            float(x)
            for x in np.round(
                np.concatenate(
                    [np.arange(50.0, 49.899, -0.02), np.arange(49.92, 50.101, 0.02), np.arange(50.08, 49.999, -0.02)]
                ),
                2,
            )
        ]
        direction = BOTH
    elif product.endswith("up") or product.endswith("down"):
        direction = UP if product.endswith("up") else DOWN
        levels = [float(x) for x in np.round(_mirror(np.array([49.9, 49.8, 49.7, 49.6, 49.5, 49.91]), direction), 2)]
    else:
        raise ValueError(product)
    pts, starts = [], []
    for k, lv in enumerate(levels):
        starts.append(k * step_time)
        pts += [(k * step_time, lv)]
        if k + 1 < len(levels):
            pts += [((k + 1) * step_time, lv)]
    t = grid(len(levels) * step_time, dt)
    marks = {"levels": levels, "step_starts": starts, "step_time": step_time}
    return TestSignal(
        f"{product} linearity steps",
        "linearity_steps",
        product,
        direction,
        t,
        piecewise(t, pts),
        marks,
        source="NTR v1.1 §3.4.2, NTP §3.3, 4.3, 6.2",
    )


def sine_periods(product: str, mode_shifting: bool = False) -> list:
    """Test periods [s]: FCR-N all ten; FCR-D 10-70 s (90, 150, 300 s only with mode shifting)."""
    if product == "FCR-N" or mode_shifting:
        return sorted(SINE_PERIODS)
    return [T for T in sorted(SINE_PERIODS) if T <= 70]


def sine_test(
    product: str,
    period: float,
    dt: float = 0.1,
    settle: float = 60.0,
    amplitude: float = 0.1,
    n_stationary: Optional[int] = None,
    n_total: Optional[int] = None,
) -> TestSignal:
    """Sine test: f = f_c for `settle` s, then f = f_c + A·sin(2π(t − settle)/T) for n_total
    periods (NTR recommended total) [Hz]; the last n_stationary periods are marked for the fit
    (the earlier ones are the lead-in that makes the response stationary). f_c = 50.0 / 49.7 /
    50.3 Hz (FCR-N / FCR-D up / FCR-D down), A = 0.1 Hz."""
    ns, nt = SINE_PERIODS.get(int(period), (5, 7))
    ns, nt = n_stationary or ns, n_total or nt
    if nt < ns:
        raise ValueError("n_total < n_stationary")
    fc = SINE_CENTRE[product]
    if abs(round(settle / dt) * dt - settle) > 1e-9 * settle:
        settle = math.ceil(settle / dt) * dt  # the lead-in ends on the step grid
    end = settle + nt * period
    t = grid(end, dt)
    ts = np.clip(t - settle, 0.0, None)
    f = fc + amplitude * np.sin(2 * np.pi * ts / period)
    marks = {
        "period": float(period),
        "centre": fc,
        "amplitude": amplitude,
        "t_sine": settle,
        "eval": (end - ns * period, end),
        "n_stationary": ns,
    }
    return TestSignal(
        f"{product} sine T = {period:g} s",
        "sine",
        product,
        UP if product == "FCR-D up" else DOWN if product == "FCR-D down" else BOTH,
        t,
        f,
        marks,
        source="NTR v1.1 §3.2 Table 6, NTP Tables 4/7/10",
    )


def ce_fcr_steps(dt: float = 0.1, hold: float = 900.0, pause: float = 300.0, pre: float = 60.0) -> TestSignal:
    """Continental FCR: 50.0 Hz for `pre` s, step to 49.8 Hz (−200 mHz, full upward) held
    `hold` s, 50.0 Hz for `pause` s, step to 50.2 Hz held `hold` s, 50.0 Hz for `pause` s.
    OUR ASSUMPTION: the German "double hump" PQ profile is unconfirmed; this stated profile is
    used instead (full activation within 30 s, SO GL Annex V; deadband ≤ 10 mHz irrelevant)."""
    a, b = pre, pre + hold
    c, d = b + pause, b + pause + hold
    end = d + pause
    pts = [(0, 50.0), (a, 50.0), (a, 49.8), (b, 49.8), (b, 50.0), (c, 50.0), (c, 50.2), (d, 50.2), (d, 50.0)]
    t = grid(end, dt)
    marks = {"steps": [(a, UP, b), (c, DOWN, d)], "fat": 30.0}
    return TestSignal(
        "CE FCR ±200 mHz steps",
        "ce_fcr_steps",
        "CE FCR",
        BOTH,
        t,
        piecewise(t, pts),
        marks,
        notes=[
            "profile 0 → −200 mHz (15 min) → 0 → +200 mHz (15 min) → 0 is our "
            "assumption; the German double-hump PQ profile is unsure (not "
            "confirmed)"
        ],
        source="SO GL Annex V; regelleistung.net",
    )


def ffr_step(
    trigger: float = 49.7,
    dt: float = 0.1,
    support: float = 30.0,
    pre: float = 10.0,
    depth: float = 0.1,
    after: float = 60.0,
) -> TestSignal:
    """FFR: 50.0 Hz for `pre` s, step to trigger − depth [Hz] held FAT + support + 10 s, back to
    50.0 Hz for `after` s. The crossing of the trigger is the step instant."""
    fat = FFR_OPTIONS[trigger]
    back = pre + fat + support + 10.0
    back = round(back / dt) * dt
    t = grid(back + after, dt)
    f = piecewise(t, [(0, 50.0), (pre, 50.0), (pre, trigger - depth), (back, trigger - depth), (back, 50.0)])
    marks = {"t_trigger": pre, "fat": fat, "trigger": trigger, "t_return": back}
    return TestSignal(
        f"FFR step below {trigger} Hz",
        "ffr_step",
        "FFR",
        UP,
        t,
        f,
        marks,
        notes=[f"step to {trigger - depth:.2f} Hz is our choice of test depth"],
        source="Fingrid FFR (developers.fingrid.fi, fingrid.fi)",
    )


def frr_step(
    product: str = "aFRR",
    direction: int = UP,
    dt: float = 0.1,
    pre: float = 60.0,
    hold: Optional[float] = None,
    after: float = 300.0,
) -> TestSignal:
    """aFRR/mFRR: a step of the reserve-power request (p.u. of the capacity; +1 = draw C less)
    at `pre` s held FAT + 300 s by default, then 0. Not frequency-driven: the driver applies
    powerReference = baseline − request·C (a load draws less for upward)."""
    fat = FRR_FAT[product]
    hold = fat + 300.0 if hold is None else hold
    t = grid(pre + hold + after, dt)
    req = direction * piecewise(t, [(0, 0.0), (pre, 0.0), (pre, 1.0), (pre + hold, 1.0), (pre + hold, 0.0)])
    marks = {"t_step": pre, "fat": fat, "t_end": pre + hold}
    return TestSignal(
        f"{product} {'up' if direction == UP else 'down'} setpoint step",
        "frr_step",
        product,
        direction,
        t,
        None,
        marks,
        request=req,
        notes=["hold of FAT + 5 min is our choice"],
        source="regelleistung.net; Elia; PICASSO/MARI standard products",
    )


def asked_response(signal: TestSignal) -> np.ndarray:
    """The static characteristic asked for [p.u. of the capacity, upward positive]:
    FCR-N clip((50 − f)/0.1, −1, 1); FCR-D up clip((49.9 − f)/0.4, 0, 1); FCR-D down
    −clip((f − 50.1)/0.4, 0, 1); CE FCR clip((50 − f)/0.2, −1, 1); FFR 1 while f < trigger;
    aFRR/mFRR the request. (Saturated at ±1: the capacity offered.)"""
    p, f = signal.product, signal.f
    if signal.request is not None:
        return signal.request
    if p == "FCR-N":
        return np.clip((50.0 - f) / 0.1, -1, 1)
    if p.endswith("FCR-D up"):
        return np.clip((49.9 - f) / 0.4, 0, 1)
    if p.endswith("FCR-D down"):
        return -np.clip((f - 50.1) / 0.4, 0, 1)
    if p == "CE FCR":
        return np.clip((50.0 - f) / 0.2, -1, 1)
    if p == "FFR":
        return (f < signal.marks["trigger"]).astype(float)
    raise ValueError(p)
