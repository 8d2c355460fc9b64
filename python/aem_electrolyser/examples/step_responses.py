#!/usr/bin/env python3
"""Step responses of the packaged FMU to setpoint steps of 5, 10, 20, 30 and 40 % (paper §III-B).

    python -m aem_electrolyser.examples.step_responses [--out out]
                                      [--duration 900] [--dt 0.1]

The FMU runs with its own start values (Table I). Negative steps go down from 100 %, positive
steps up from 60 %, so both stay in the 60...100 % window. The model is linear and the rate
limit acts on the change of current, so the response to a step depends on its size and sign
only, not on the level it starts from: the paper's pre-step-mean-removed curves are these
minus their start value. Prints, per step, the time to 90 % of the final change (t90), the
current at t90 relative to the final value, the time to within 2 % of the change (t98: the
slow creep of the tauZero/tauPole2 mode), the overshoot in % of the step and the current at
the end. Writes <out>/step_responses.csv (current [A] of every run against time [s] since the
step), <out>/step_responses_table.csv (the table) and <out>/step_responses.png before it prints
the table; the FMU's messages go to stderr.
"""

import contextlib
import csv
import shutil
import sys

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from aem_electrolyser.extras import require
from aem_electrolyser import cli
from aem_electrolyser.hub.messages import fmu_words, instantiate

SIZES = [5, 10, 20, 30, 40]  # step sizes [% of nominal]
TOP, BOTTOM = 100.0, 60.0  # start levels of negative and positive steps [%]
PRE = 60.0  # seconds simulated before the step
TABLE_HEADER = [
    "direction",
    "from [%]",
    "to [%]",
    "change [A]",
    "final K*u [A]",
    "t90 [s]",
    "I(t90)/final [%]",
    "t98 [s]",
    "overshoot [% of step]",
    "I(end) [A]",
]


def runs():
    """(label, from [%], to [%]) of every step: negative steps first."""
    return [(f"-{s} %", TOP, TOP - s) for s in SIZES] + [(f"+{s} %", BOTTOM, BOTTOM + s) for s in SIZES]


def simulate_steps(fmu, steps, duration, dt, quiet=True):
    """Current [A] on t = -PRE...duration [s] (step at t = 0) of each (from, to) setpoint pair
    (a progress bar over the steps unless quiet)."""
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipdir = extract(str(fmu))
    n_pre, n_post = int(round(PRE / dt)), int(round(duration / dt))
    t = dt * np.arange(-n_pre, n_post + 1)
    currents = []
    try:
        for u0, u1 in cli.progress(steps, desc="step responses", unit="step", quiet=quiet):
            slave = FMU2Slave(
                guid=md.guid,
                unzipDirectory=unzipdir,
                modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName="steps",
            )
            instantiate(slave, echo=True)
            with fmu_words(f"the step from {u0:g} to {u1:g} %"):
                slave.setupExperiment(startTime=t[0])
                slave.setReal([vr["setpoint"]], [u0])  # starts in steady state at u0
                slave.enterInitializationMode()
                slave.exitInitializationMode()
                current = [slave.getReal([vr["current"]])[0]]
                for k in range(len(t) - 1):
                    slave.setReal([vr["setpoint"]], [u0 if t[k] < 0 else u1])
                    slave.doStep(currentCommunicationPoint=t[k], communicationStepSize=dt)
                    current.append(slave.getReal([vr["current"]])[0])
            slave.terminate()
            slave.freeInstance()
            currents.append(np.array(current))
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    gain = float(next(v.start for v in md.modelVariables if v.name == "gain"))
    return t, currents, gain


def crossing(t, y, level):
    """First time [s] y reaches `level` (y rising), linearly interpolated; NaN if never."""
    k = np.flatnonzero(y >= level)
    if len(k) == 0:
        return float("nan")
    k = k[0]
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (level - y[k - 1]) / (y[k] - y[k - 1]) * (t[k] - t[k - 1]))


def metrics(t, current, u0, u1, gain):
    """One table row: the step's change, t90, current at t90, t98, overshoot and end value."""
    start, final = gain * u0, gain * u1
    sign = np.sign(final - start)
    after = t >= 0
    progress = sign * (current[after] - start) / abs(final - start)  # 0 before, 1 at the final value
    t90 = crossing(t[after], progress, 0.9)
    t98 = crossing(t[after], progress, 0.98)
    i90 = np.interp(t90, t, current)
    overshoot = 100.0 * max(0.0, progress.max() - 1.0)
    return [final - start, final, t90, 100.0 * i90 / final, t98, overshoot, current[-1]]


def write_csvs(out, t, labeled, currents, table):
    with open(out / "step_responses.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time since step [s]"] + [f"current {lab} ({u0:g}->{u1:g} %) [A]" for lab, u0, u1 in labeled])
        for k in range(len(t)):
            w.writerow([f"{t[k]:.6g}"] + [f"{c[k]:.10g}" for c in currents])
    with open(out / "step_responses_table.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TABLE_HEADER)
        w.writerows([[f"{x:.10g}" if isinstance(x, float) else x for x in row] for row in table])


def plot(path, t, labeled, currents, table, dpi):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 5.4), sharex=True)
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, len(SIZES)))
    for i, ((label, u0, u1), current, row) in enumerate(zip(labeled, currents, table)):
        ax = axes[0] if label.startswith("+") else axes[1]
        c = colours[i % len(SIZES)]
        ax.plot(t, current, color=c, lw=1.3, label=f"{label} ({u0:g} → {u1:g} %): t90 {row[5]:.1f} s")
        ax.axhline(row[4], color=c, lw=0.6, ls=":")
        ax.plot([row[5]], [np.interp(row[5], t, current)], "o", color=c, ms=4)
    titles = ["Positive steps from 60 % (rate limit, then G(s))", "Negative steps from 100 % (G(s) only)"]
    for ax, title in zip(axes, titles):
        ax.set_title(title, fontsize=10)
        ax.set_xlim(t[0], min(t[-1], 480.0))
        ax.set_xlabel("time since the setpoint step [s]")
        ax.set_ylabel("stack current [A]")
        ax.grid(alpha=0.3)
        ax.legend(
            fontsize=7.5,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.16),
            ncol=2,
            title="setpoint step (dot: 90 % of the change reached; dotted line: final value K·u)",
            title_fontsize=7.5,
        )
    fig.suptitle("AEM module FMU (Table I parameters): current response to setpoint steps", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def print_table(table):
    print(
        f"{'step':>6} {'from→to [%]':>12} {'ΔI [A]':>8} {'K·u [A]':>8} {'t90 [s]':>8} {'I(t90)/final':>12} "
        f"{'t98 [s]':>8} {'overshoot':>9} {'I(end) [A]':>10}"
    )
    for label, u0, u1, di, final, t90, i90, t98, over, end in table:
        print(
            f"{label:>6} {f'{u0:g}→{u1:g}':>12} {di:8.3f} {final:8.3f} {t90:8.1f} {i90:11.2f}% "
            f"{t98:8.1f} {over:8.2f}% {end:10.4f}"
        )


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    cli.add_out_option(parser, "out", "step_responses.csv, step_responses_table.csv and step_responses.png")
    parser.add_argument(
        "--duration", type=cli.positive(float), default=900.0, help="seconds simulated after the step [default: 900]"
    )
    parser.add_argument("--dt", type=cli.positive(float), default=0.1, help="communication step [s] [default: 0.1]")
    parser.add_argument("--dpi", type=cli.positive(int), default=110, help="resolution of the PNG [default: 110]")
    args = parser.parse_args(argv)
    if args.dt > args.duration:
        parser.error(f"--dt: {args.dt:g} s is longer than --duration {args.duration:g} s")
    require("plots", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    cli.writable_folder(args.out)
    labeled = runs()
    with contextlib.redirect_stdout(sys.stderr):  # the FMU's log is no report
        t, currents, gain = simulate_steps(
            args.fmu, [(u0, u1) for _, u0, u1 in labeled], args.duration, args.dt, args.quiet
        )
    table = [[lab, u0, u1] + metrics(t, c, u0, u1, gain) for (lab, u0, u1), c in zip(labeled, currents)]
    write_csvs(args.out, t, labeled, currents, table)
    plot(args.out / "step_responses.png", t, labeled, currents, table, args.dpi)
    if args.quiet:
        return
    print_table(table)
    print(
        f"wrote {args.out / 'step_responses.csv'}, {args.out / 'step_responses_table.csv'} and {args.out / 'step_responses.png'}"
    )


if __name__ == "__main__":
    cli.run_command(main)
