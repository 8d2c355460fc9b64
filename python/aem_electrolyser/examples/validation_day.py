#!/usr/bin/env python3
"""Validation on a held-out day, as in the paper's §III-E, on a synthetic campaign with known truth.

    python -m aem_electrolyser.examples.validation_day [--out out] [--days 10] [--seed 2026] [--hours H]

1. `aem-identify synthesize`: a seeded campaign of --days days (1 Hz, 0.15 A current noise,
   temperature dips, start-up and shut-down each day) and the next day as held-out day;
2. `aem-identify fit` on the campaign -> <out>/validation/params.json;
3. `packaging/package.py --parameters` -> <out>/validation/AemIdentified.fmu, an FMU whose start
   values are the identified parameters (this rebuilds the release library; the repository's
   packaged FMU is not touched; this step needs a source checkout);
4. that FMU in fmpy, driven by the held-out day's setpoints through its running segment (from
   steady state at the first setpoint; row n's setpoint acts from row n-1 on), compared with
   the measured current, voltage and DC power (V*I) on the rows at least 600 s after start-up
   (the model does not cover start-ups); `aem-identify validate` is run beside as a cross-check.

Writes <out>/validation_day.csv (measured and simulated, every running row),
<out>/validation_day.png and <out>/validation_parameters.csv, then prints the identified
parameters against the true ones and the RMSEs. The commands it runs are echoed on stderr.
"""

import contextlib
import csv
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from aem_electrolyser import locate
from aem_electrolyser import cli
from aem_electrolyser.extras import require

SETTLE = 600.0  # rows this long after a start-up are compared [s]
RUNNING_CURRENT = 1.0  # a row runs above this current [A] with a setpoint > 0
PARAMETERS = [
    "gain",
    "tauZero",
    "tauPole1",
    "tauPole2",
    "rampUpLimit",
    "voltageIntercept",
    "ohmicResistance",
    "h2Coefficient",
]


class StageFailed(RuntimeError):
    """A command of the pipeline failed: its name, status and last words."""


def run(cmd, log=None):
    """Runs a command and returns its stdout; StageFailed with its last line of stderr on failure."""
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != 0:
        said = (p.stderr.strip() or p.stdout.strip() or "no message").splitlines()[-1]
        raise StageFailed(f"{Path(str(cmd[0])).name} {cmd[1]} failed (exit status {p.returncode}): {said}")
    if log is not None:
        log.write_text(p.stdout)
    return p.stdout


def synthesize(tool, work, days, seed, hours):
    """Campaign and held-out day files; the true parameters {name: (value, unit)}."""
    extra = ["--seed", seed] + (["--hours", hours] if hours else [])
    shutil.rmtree(work / "campaign", ignore_errors=True)
    shutil.rmtree(work / "heldout", ignore_errors=True)
    out = run([tool, "synthesize", work / "campaign", "--days", days] + extra)
    run([tool, "synthesize", work / "heldout", "--days", 1, "--skip", days] + extra)
    truth = {
        name: (float(value), unit)
        for name, value, unit in re.findall(r"(\w+) ([-0-9.e]+) ([^,\s]+)", out.split("truth:")[1])
    }
    return truth, work / "heldout" / "day01.csv"


def identified(params_json):
    """{name: (value, standard error)} of the only module in an `aem-identify fit -o` file."""
    entry = json.loads(params_json.read_text())["modules"][0]["parameters"]
    return {n: (e["value"], e.get("standardError", float("nan"))) for n, e in entry.items()}


def load_day(path):
    """Columns of a synthetic day as float arrays."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def simulate(fmu, time, setpoint):
    """Current [A], voltage [V], power [W] of the FMU driven by the setpoints of one segment."""
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [vr["current"], vr["voltage"], vr["power"]]
    unzipdir = extract(str(fmu))
    try:
        slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="heldout",
        )
        slave.instantiate()
        slave.setupExperiment(startTime=time[0])
        slave.setReal([vr["setpoint"]], [setpoint[0]])  # steady state at the first setpoint
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        result = [slave.getReal(outputs)]
        for r in range(1, len(time)):
            slave.setReal([vr["setpoint"]], [setpoint[r]])  # acts over (t[r-1], t[r]]
            slave.doStep(currentCommunicationPoint=time[r - 1], communicationStepSize=time[r] - time[r - 1])
            result.append(slave.getReal(outputs))
        slave.terminate()
        slave.freeInstance()
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    return np.array(result).T


def compare(fmu, day):
    """Measured and simulated values of every running row, and which rows are compared."""
    running = (day["current"] > RUNNING_CURRENT) & (day["setpoint"] > 0)
    edges = np.flatnonzero(np.diff(np.r_[0, running.astype(int), 0]))
    rows = {
        k: [] for k in ("time", "setpoint", "current", "voltage", "current_sim", "voltage_sim", "power_sim", "compared")
    }
    for start, stop in zip(edges[::2], edges[1::2]):
        t, u = day["time"][start:stop], day["setpoint"][start:stop]
        i_sim, v_sim, p_sim = simulate(fmu, t, u)
        for key, values in [
            ("time", t),
            ("setpoint", u),
            ("current", day["current"][start:stop]),
            ("voltage", day["voltage"][start:stop]),
            ("current_sim", i_sim),
            ("voltage_sim", v_sim),
            ("power_sim", p_sim),
            ("compared", t - t[0] >= SETTLE),
        ]:
            rows[key].append(values)
    rows = {k: np.concatenate(v) for k, v in rows.items()}
    rows["power"] = rows["current"] * rows["voltage"]
    return rows


def rmse(rows, key):
    c = rows["compared"]
    return float(np.sqrt(np.mean((rows[key][c] - rows[key + "_sim"][c]) ** 2)))


def plot(path, rows, rmses, dpi):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hours = (rows["time"] % 86400.0) / 3600.0  # time of day (UTC) [h]
    panels = [
        ("current", "Stack current", "[A]", "A", 1.0),
        ("voltage", "Stack voltage", "[V]", "V", 1.0),
        ("power", "DC power", "[kW]", "W", 1e-3),
    ]
    fig, axes = plt.subplots(4, 1, figsize=(10, 8.4), sharex=True, gridspec_kw={"height_ratios": [1, 2, 2, 2]})
    c = rows["compared"]
    axes[0].step(hours, rows["setpoint"], where="post", color="tab:gray")
    axes[0].set_ylabel("setpoint [%]")
    axes[0].set_title("Held-out day: setpoint sent to the module (and to the FMU)", fontsize=9, loc="left")
    for ax, (key, name, axis_unit, unit, scale) in zip(axes[1:], panels):
        ax.plot(hours, scale * rows[key], color="0.55", lw=0.6, label="measured (synthetic, with sensor noise)")
        ax.plot(hours, scale * rows[key + "_sim"], color="tab:blue", lw=1.0, label="identified FMU in fmpy")
        ax.set_ylabel(f"{name.lower() if name[1].islower() else name} {axis_unit}")
        ax.set_title(
            f"{name}: RMSE {rmses[key]:.4g} {unit} (rows ≥ {SETTLE:.0f} s after start-up)", fontsize=9, loc="left"
        )
        lo, hi = scale * rows[key][c].min(), scale * rows[key][c].max()
        ax.set_ylim(lo - 0.08 * (hi - lo), hi + 0.08 * (hi - lo))  # the start-up from 0 runs off the bottom
    for ax in axes:
        ax.fill_between(
            hours,
            0,
            1,
            where=~c,
            transform=ax.get_xaxis_transform(),
            color="tab:orange",
            alpha=0.15,
            lw=0,
            label="start-up (not compared)",
        )
        ax.grid(alpha=0.3)
    axes[1].legend(loc="upper left", fontsize=8)
    axes[-1].set_xlabel("time of day (UTC) [h]")
    fig.suptitle(
        "Validation of the identified model on a held-out day (synthetic campaign with known parameters)", fontsize=11
    )
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def write_outputs(out, rows, table):
    keys = ["time", "setpoint", "current", "current_sim", "voltage", "voltage_sim", "power", "power_sim", "compared"]
    header = [
        "time [s]",
        "setpoint [%]",
        "current measured [A]",
        "current FMU [A]",
        "voltage measured [V]",
        "voltage FMU [V]",
        "power measured [W]",
        "power FMU [W]",
        "compared",
    ]
    with open(out / "validation_day.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in range(len(rows["time"])):
            w.writerow([f"{float(rows[k][r]):.10g}" if k != "compared" else int(rows[k][r]) for k in keys])
    with open(out / "validation_parameters.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["parameter", "unit", "true", "identified", "standard error", "error [%]"])
        w.writerows(table)


STAGES = ("synthesize the campaign", "fit", "package the identified FMU", "validate", "compare on the held-out day")


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_out_option(
        parser, "out", "validation_day.csv, validation_parameters.csv, validation_day.png and validation/"
    )
    parser.add_argument(
        "--days",
        type=cli.positive(int),
        default=10,
        help="training days (the held-out day is the next one) [default: 10]",
    )
    parser.add_argument("--seed", type=int, default=2026, help="seed of the synthetic campaign [default: 2026]")
    parser.add_argument(
        "--hours", type=cli.positive(float), help="running hours per day, at most 23 [default: the generator's 8.2 h]"
    )
    parser.add_argument("--tool", type=Path, help="aem-identify [default: the one of this installation]")
    parser.add_argument("--dpi", type=cli.positive(int), default=110, help="resolution of the PNG [default: 110]")
    args = parser.parse_args(argv)
    if args.hours is not None and args.hours > 23:
        parser.error(f"--hours: {args.hours:g} h do not fit a day with its start-up and shut-down (at most 23)")
    if args.tool is not None and not args.tool.is_file():
        parser.error(f"--tool: {args.tool} does not exist")
    require("plots", parser.prog)
    checkout = locate.checkout()
    if checkout is None:
        sys.exit(
            f"{parser.prog}: error: it rebuilds the FMU with the identified parameters (packaging/package.py): "
            "run it in a source checkout of aem-electrolyser"
        )
    try:
        args.tool = args.tool or locate.binary("aem-identify")
    except locate.NotBuilt as e:
        parser.error(f"--tool: {e}")
    out = cli.writable_folder(args.out).resolve()
    work = cli.writable_folder(out / "validation")

    with cli.progress(total=len(STAGES), desc="validation day", unit="stage", quiet=args.quiet) as bar:
        bar.set_postfix_str(STAGES[0])
        truth, heldout = synthesize(args.tool, work, args.days, args.seed, args.hours)
        bar.update()
        bar.set_postfix_str(STAGES[1])
        params = work / "params.json"
        run([args.tool, "fit", work / "campaign", "-o", params], log=work / "fit_report.txt")
        bar.update()
        bar.set_postfix_str(STAGES[2])
        fmu = work / "AemIdentified.fmu"
        run([sys.executable, checkout / "packaging" / "package.py", "--parameters", params, "--output", fmu])
        bar.update()
        bar.set_postfix_str(STAGES[3])
        check = run([args.tool, "validate", params, heldout])
        bar.update()
        bar.set_postfix_str(STAGES[4])
        with contextlib.redirect_stdout(sys.stderr):  # the FMU's log is no report
            rows = compare(fmu, load_day(heldout))
        bar.update()

    found = identified(params)
    table = []
    for name in PARAMETERS:
        (true, unit), (value, se) = truth[name], found[name]
        table.append([name, unit, true, value, se, 100.0 * (value / true - 1.0)])
    rmses = {k: rmse(rows, k) for k in ("current", "voltage", "power")}
    tool_rmse = float(re.search(r"RMSE current\s+([0-9.]+) A", check).group(1))
    write_outputs(out, rows, table)
    plot(out / "validation_day.png", rows, rmses, args.dpi)
    if args.quiet:
        return

    print(f"{'parameter':<17} {'unit':<9} {'true':>10} {'identified':>12} {'std. error':>11} {'error':>8}")
    for name, unit, true, value, se, error in table:
        print(f"{name:<17} {unit:<9} {true:10.5g} {value:12.6g} {se:11.2g} {error:+7.3f}%")
    print(f"\nheld-out day {heldout.name}: {int(rows['compared'].sum())} of {len(rows['time'])} running rows compared")
    print(
        f"RMSE current {rmses['current']:.4f} A (aem-identify validate: {tool_rmse:.4f} A), "
        f"voltage {rmses['voltage']:.4f} V, DC power {rmses['power']:.3f} W"
    )
    print(f"wrote {out / 'validation_day.csv'}, {out / 'validation_parameters.csv'} and {out / 'validation_day.png'}")


if __name__ == "__main__":
    cli.run_command(main)
