#!/usr/bin/env python3
"""A straightforward Python/NumPy/SciPy implementation of aem-identify's pipeline, the peer of
the Rust tool in benches/identify_bench.sh (same files, same run).

    python benches/identify_reference.py DIR [--json]

Same steps and rules as the Rust tool: CSV reading with bad-row accounting and gap splitting,
running segments, steps during steady running (row n's setpoint acts from row n-1 on; 60 s
pre-step window; 600 s settle), polarisation at 55 +- 0.1 degC / 29 +- 0.1 bar, K, tauZ,
tauP1, tauP2 on the negative steps clear of the rate limit (scipy.optimize.least_squares,
loose fit, outliers, tight fit), the ramp limit on the positive steps, first/third-order
candidates, and the hydrogen coefficient. What a user would write in a notebook: the linear
responses come from scipy.signal.lfilter of the exact zero-order-hold discretisation on the
1 s grid, the rate limit from the discrete rule I[n] = min(I[n-1] + r*dt, I_tf[n]) via a
running minimum (the FMU is exact between samples, this is not), standard errors from
(J^T J)^-1 without the per-step clustering. Prints the parameters and the wall time per stage.
"""

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter
from aem_electrolyser.cli import quiet_on_closed_stdout

COLUMNS = ["time", "setpoint", "current", "voltage", "temperature", "pressure", "h2_flow"]
MAX_GAP, RUNNING_CURRENT, SETTLE, PRE_WINDOW, MIN_RESPONSE = 10.0, 1.0, 600.0, 60.0, 60.0
LEVEL_TOL, MIN_STEP, WINDOW = 0.5, 1.0, (60.0, 100.0)
UNLIMITED = 1e9


def read(paths):
    """Blocks (dict of column arrays) split at gaps, and bad-row counts."""
    bad = dict(empty=0, nan=0, text=0, short=0, duplicate=0, backwards=0, gaps=0)
    blocks = []
    for path in paths:
        with open(path, newline="") as f:
            reader = csv.reader(f)
            header = [h.strip() for h in next(reader)]
            idx = [header.index(c) for c in COLUMNS]
            rows, last = [], None
            for fields in reader:
                if len(fields) <= max(idx):
                    bad["short"] += 1
                    continue
                values = []
                for i in idx:
                    text = fields[i].strip()
                    if not text:
                        values = "empty"
                        break
                    try:
                        v = float(text)
                    except ValueError:
                        values = "text"
                        break
                    if not math.isfinite(v):
                        values = "nan"
                        break
                    values.append(v)
                if isinstance(values, str):
                    bad[values] += 1
                    continue
                t = values[0]
                if last is not None:
                    if t == last:
                        bad["duplicate"] += 1
                        continue
                    if t < last:
                        bad["backwards"] += 1
                        continue
                    if t - last > MAX_GAP:
                        bad["gaps"] += 1
                        blocks.append(np.array(rows))
                        rows = []
                rows.append(values)
                last = t
            if rows:
                blocks.append(np.array(rows))
    return [dict(zip(COLUMNS, b.T)) for b in blocks], bad


def segments(blocks):
    out = []
    for b in blocks:
        running = (b["current"] > RUNNING_CURRENT) & (b["setpoint"] > 0)
        edges = np.flatnonzero(np.diff(np.concatenate(([0], running.astype(int), [0]))))
        for s, e in zip(edges[::2], edges[1::2]):
            if e - s >= 2:
                out.append({k: b[k][s:e] for k in ("time", "setpoint", "current")})
    return out


def find_steps(segs):
    steps = []
    for si, seg in enumerate(segs):
        t, u = seg["time"], seg["setpoint"]
        starts = [0]
        for n in range(1, len(u)):
            if abs(u[n] - u[starts[-1]]) > LEVEL_TOL:
                starts.append(n)
        starts.append(len(u))
        for w in range(1, len(starts) - 1):
            p, n, e = starts[w - 1], starts[w], starts[w + 1]
            a, b, t0 = u[p], u[n], t[n - 1]
            inside = WINDOW[0] - 1e-9 <= a <= WINDOW[1] + 1e-9 and WINDOW[0] - 1e-9 <= b <= WINDOW[1] + 1e-9
            if not inside or abs(b - a) < MIN_STEP or t0 - t[p] < PRE_WINDOW:
                continue
            if t0 - PRE_WINDOW < t[0] + SETTLE or t[e - 1] - t0 < MIN_RESPONSE:
                continue
            pre0 = p + np.searchsorted(t[p:n], t0 - PRE_WINDOW)
            steps.append(dict(seg=si, pre=(pre0, n), post=(n, e), size=b - a, pre_mean=seg["current"][pre0:n].mean()))
    return steps


def grid_setpoint(seg, window):
    """Setpoint on the 1 s grid of the segment (row n's setpoint held over (t[n-1], t[n]])
    and the grid index of every row."""
    k = np.rint(seg["time"] - seg["time"][0]).astype(int)
    u = np.clip(seg["setpoint"], *window)
    grid = np.empty(k[-1] + 1)
    grid[k] = u
    # Missing seconds take the next row's setpoint.
    owner = np.searchsorted(k, np.arange(k[-1] + 1))
    return u[owner], k


def modal_current(u, gain, taus, weights):
    """Exact 1 s response of K*sum w_i/(tau_i s + 1) from steady state at u[0]."""
    y = gain * u
    out = np.zeros_like(y)
    for tau, w in zip(taus, weights):
        d = math.exp(-1.0 / tau)
        # z[n] = d z[n-1] + (1 - d) y[n], with z[-1] = y[0] (steady state).
        z, _ = lfilter([1.0 - d], [1.0, -d], y, zi=[d * y[0]])
        out += w * z
    return out


def limited(current_tf, r):
    """Discrete rising-rate limit on the 1 s grid: I[n] = min(I[n-1] + r, I_tf[n])."""
    n = np.arange(len(current_tf))
    return r * n + np.minimum.accumulate(current_tf - r * n)


class StepProblem:
    def __init__(self, segs, steps, chosen):
        self.segs, self.steps = segs, steps
        self.by_seg = {}
        for k in chosen:
            self.by_seg.setdefault(steps[k]["seg"], []).append(k)
        self.grids = {s: grid_setpoint(segs[s], WINDOW) for s in self.by_seg}

    def residuals(self, gain, taus, weights, ramp=None):
        out = []
        for s, ks in self.by_seg.items():
            u, k = self.grids[s]
            model = modal_current(u, gain, taus, weights)
            if ramp is not None:
                model = limited(model, ramp)
            model = model[k]
            cur = self.segs[s]["current"]
            for j in ks:
                st = self.steps[j]
                (a, b), (c, d) = st["pre"], st["post"]
                out.append((cur[c:d] - st["pre_mean"]) - (model[c:d] - model[a:b].mean()))
        return np.concatenate(out)


def second_order(theta):
    k, tz, t1, t2 = np.exp(theta[:4])
    a = (tz - t1) / (t2 - t1)
    return k, (t1, t2), (a, 1.0 - a)


def initial_guess(segs, steps, neg):
    s = np.zeros(601)
    c = np.zeros(601)
    for j in neg:
        st = steps[j]
        seg = segs[st["seg"]]
        lo, hi = st["post"]
        lag = np.rint(seg["time"][lo:hi] - seg["time"][lo - 1]).astype(int)
        ok = (lag >= 1) & (lag <= 600)
        np.add.at(s, lag[ok], (seg["current"][lo:hi][ok] - st["pre_mean"]) / st["size"])
        np.add.at(c, lag[ok], 1)
    t = np.flatnonzero(c)
    g = s[t] / c[t]
    best = None
    for t1 in np.geomspace(0.2, 60, 25):
        for t2 in np.geomspace(5, 3000, 31):
            if t2 < 1.5 * t1:
                continue
            basis = np.column_stack([1 - np.exp(-t / t1), 1 - np.exp(-t / t2)])
            coef, res, *_ = np.linalg.lstsq(basis, g, rcond=None)
            rss = float(np.sum((g - basis @ coef) ** 2))
            if coef.sum() > 0 and (best is None or rss < best[0]):
                best = (rss, t1, t2, coef)
    _, t1, t2, (c1, c2) = best
    k = c1 + c2
    tz = max(t1 + c1 / k * (t2 - t1), 0.05 * t2)
    return np.log([k, tz, t1, t2])


def fit_with_outliers(problem_for, steps, chosen, fun, x0):
    first = least_squares(lambda x: fun(problem_for(chosen), x), x0, method="lm", ftol=1e-6, xtol=1e-6)
    prob = problem_for(chosen)
    r = fun(prob, first.x)
    rms, off = [], 0
    for s, ks in prob.by_seg.items():
        for j in ks:
            n = steps[j]["post"][1] - steps[j]["post"][0]
            rms.append(math.sqrt(np.mean(r[off : off + n] ** 2)))
            off += n
    order = [j for ks in prob.by_seg.values() for j in ks]
    rms = np.array(rms)
    med = np.median(rms)
    limit = med + 5 * 1.4826 * np.median(np.abs(rms - med))
    kept = [j for j, v in zip(order, rms) if v <= limit] if len(rms) >= 5 else order
    final = least_squares(lambda x: fun(problem_for(kept), x), first.x, method="lm", ftol=1e-12, xtol=1e-12)
    return final, kept


def standard_errors(result):
    j = result.jac
    s2 = 2 * result.cost / (j.shape[0] - j.shape[1])
    cov = np.linalg.inv(j.T @ j) * s2
    return np.sqrt(np.diag(cov)), cov


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir", type=Path)
    parser.add_argument("--json", action="store_true", help="print the stage times as JSON on the last line")
    args = parser.parse_args(argv)
    files = sorted(p for p in args.dir.iterdir() if p.suffix == ".csv")
    times = {}
    t0 = clock = time.perf_counter()

    def lap(name):
        nonlocal clock
        now = time.perf_counter()
        times[name] = now - clock
        clock = now

    blocks, bad = read(files)
    lap("read")
    segs = segments(blocks)
    steps = find_steps(segs)
    lap("segments and steps")

    # Polarisation.
    cur = np.concatenate([b["current"] for b in blocks])
    volt = np.concatenate([b["voltage"] for b in blocks])
    temp = np.concatenate([b["temperature"] for b in blocks])
    pres = np.concatenate([b["pressure"] for b in blocks])
    m = (cur > RUNNING_CURRENT) & (np.abs(temp - 55) <= 0.1) & (np.abs(pres - 29) <= 0.1)
    r_ohm, v0 = np.polyfit(cur[m], volt[m], 1)
    lap("polarisation")

    # Dynamics: negative steps clear of the rate limit, then the ramp on the positive steps.
    neg = [j for j, s in enumerate(steps) if s["size"] < 0]
    pos = [j for j, s in enumerate(steps) if s["size"] > 0]
    x0 = initial_guess(segs, steps, neg)
    slopes = []
    big = np.median([steps[j]["size"] for j in pos])
    for j in pos:
        st = steps[j]
        if st["size"] < big:
            continue
        seg = segs[st["seg"]]
        lo, hi = st["post"]
        lag = seg["time"][lo:hi] - seg["time"][lo - 1]
        i = np.flatnonzero(lag <= 6.0)
        if len(i):
            slopes.append((seg["current"][lo + i[-1]] - st["pre_mean"]) / lag[i[-1]])
    r0 = float(np.median([s for s in slopes if s > 0]))

    def on_ramp(theta, r):
        gain, taus, w = second_order(theta)
        flags = {}
        for s, seg in enumerate(segs):
            u, k = grid_setpoint(seg, WINDOW)
            tf = modal_current(u, gain, taus, w)
            flags[s] = (limited(tf, r) < tf - 1e-9)[k]
        return flags

    flags = on_ramp(x0, r0)
    clean = [j for j in neg if not flags[steps[j]["seg"]][steps[j]["pre"][0] : steps[j]["post"][1]].any()]
    linear = lambda prob, x: prob.residuals(*second_order(x))
    lin, neg_used = fit_with_outliers(lambda ch: StepProblem(segs, steps, ch), steps, clean, linear, x0)
    gain, taus, w = second_order(lin.x)
    ramp_fun = lambda prob, x: prob.residuals(gain, taus, w, ramp=math.exp(x[0]))
    rfit, pos_used = fit_with_outliers(lambda ch: StepProblem(segs, steps, ch), steps, pos, ramp_fun, np.log([r0]))
    se, cov = standard_errors(lin)
    lap("current dynamics")

    # Structure check: orders 1 and 3 on the same negative steps.
    prob = StepProblem(segs, steps, neg_used)
    k2, tz, t1, t2 = np.exp(lin.x)
    a = (tz - t1) / (t2 - t1)
    n_res = len(prob.residuals(gain, taus, w))
    aicc = lambda rss, k: n_res * math.log(rss / n_res) + 2 * k + 2 * k * (k + 1) / (n_res - k - 1)
    o1 = least_squares(
        lambda x: prob.residuals(math.exp(x[0]), (math.exp(x[1]),), (1.0,)),
        [math.log(k2), math.log(a * t1 + (1 - a) * t2)],
        method="lm",
        ftol=1e-6,
    )
    o3 = least_squares(
        lambda x: prob.residuals(math.exp(x[0]), tuple(np.exp(x[1:4])), (x[4], x[5], 1 - x[4] - x[5])),
        [math.log(k2), math.log(t1), math.log(t2), math.log(math.sqrt(t1 * t2)), 0.95 * a, 0.95 * (1 - a)],
        method="lm",
        ftol=1e-6,
    )
    rss2 = float(np.sum(prob.residuals(gain, taus, w) ** 2))
    structure = {1: aicc(2 * o1.cost, 2), 2: aicc(rss2, 4), 3: aicc(2 * o3.cost, 6)}
    lap("structure check")

    # Hydrogen.
    h2 = np.concatenate([b["h2_flow"] for b in blocks])
    run = cur > RUNNING_CURRENT
    c = float(np.sum(h2[run] * cur[run]) / np.sum(cur[run] ** 2))
    lap("hydrogen")
    total = time.perf_counter() - t0

    print(f"rows: {sum(len(b['time']) for b in blocks)} used; bad: {bad}")
    print(
        f"steps: {len(steps)} qualify; negative used {len(neg_used)} of {len(neg)}, positive used {len(pos_used)} of {len(pos)}"
    )
    print(f"voltageIntercept {v0:.5g} V  ohmicResistance {r_ohm:.5g} Ohm")
    print(
        f"gain {k2:.5g} A/%  tauZero {tz:.5g} s  tauPole1 {t1:.5g} s  tauPole2 {t2:.5g} s  (rel. SE {np.round(se, 5)})"
    )
    print(f"rampUpLimit {math.exp(rfit.x[0]):.5g} A/s  h2Coefficient {c:.5g} Nl/(h.A)")
    print(
        "structure AICc - min: "
        + ", ".join(f"order {o}: {v - min(structure.values()):.4g}" for o, v in structure.items())
    )
    for name, seconds in times.items():
        print(f"python: {name:<20} {1e3 * seconds:9.1f} ms")
    print(f"python: total {1e3 * total:9.1f} ms")
    if args.json:
        print(json.dumps({"total": total, **times}))


if __name__ == "__main__":
    quiet_on_closed_stdout(lambda: sys.exit(main()))
