#!/usr/bin/env python3
"""Demo: one AEM module follows a setpoint step schedule, simulated by fmpy.

    python -m aem_electrolyser.examples.step_schedule [--out out]

Writes <out>/step_schedule.csv (every second) and step_schedule.png (current, voltage, power and hydrogen flow
against time), then prints a short table; the FMU's messages go to stderr. Steps
down follow the two-exponential response of G(s); steps up are held to the 0.22 A/s ramp limit
until the response catches up.
"""

import csv

import numpy as np
from fmpy import read_model_description, simulate_fmu
from aem_electrolyser.extras import require
from aem_electrolyser import cli
from aem_electrolyser.hub.messages import log_to_stderr, refusal


#: (time [s], setpoint [%]): hold, step down, step up, leave the window, return.
SCHEDULE = [(0, 100), (300, 60), (900, 80), (1500, 100), (2100, 40), (2400, 70), (3000, 100)]
STOP_TIME = 3600.0
OUTPUTS = ["setpoint", "current", "voltage", "power", "h2Flow", "energy", "h2Produced"]


def input_signal(model_description):
    """Piecewise-constant setpoint as fmpy's structured input (repeated times mark steps).

    fmpy expects a column for every input of the FMU; the inputs this demo does not drive
    (`powerReference`, which a module in setpoint mode ignores) are held at their start values.
    """
    rows = []
    for i, (t, sp) in enumerate(SCHEDULE):
        if i > 0:
            rows.append((t, SCHEDULE[i - 1][1]))
        rows.append((t, sp))
    rows.append((STOP_TIME, SCHEDULE[-1][1]))
    held = [v for v in model_description.modelVariables if v.causality == "input" and v.name != "setpoint"]
    dtype = [("time", np.float64), ("setpoint", np.float64)] + [(v.name, np.float64) for v in held]
    return np.array([row + tuple(float(v.start) for v in held) for row in rows], dtype=dtype)


def simulate(fmu):
    signal = input_signal(read_model_description(str(fmu)))
    try:  # the FMU's warnings go to stderr; a refusal ends in one error in its words
        return simulate_fmu(
            str(fmu),
            start_time=0.0,
            stop_time=STOP_TIME,
            step_size=1.0,
            output_interval=1.0,
            input=signal,
            output=OUTPUTS,
            logger=log_to_stderr,
        )
    except Exception as e:  # noqa: BLE001 - fmpy raises plain Exceptions
        raise refusal(f"the simulation ({e})") from None


def write_csv(result, path):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            [
                "time [s]",
                "setpoint [%]",
                "current [A]",
                "voltage [V]",
                "power [W]",
                "h2Flow [Nl/h]",
                "energy [J]",
                "h2Produced [Nl]",
            ]
        )
        for row in result:
            w.writerow([f"{x:.10g}" for x in row])


def plot(result, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = result["time"] / 60.0
    fig, axes = plt.subplots(5, 1, figsize=(9, 10.5), sharex=True)
    axes[0].step(t, result["setpoint"], where="post", color="tab:gray", label="setpoint (requested)")
    axes[0].set_ylabel("setpoint [%]")
    axes[0].axhspan(60, 100, color="tab:green", alpha=0.08, label="operating window")
    axes[0].legend(loc="lower right", fontsize=8)
    axes[1].plot(t, result["current"], color="tab:blue")
    axes[1].set_ylabel("current [A]")
    axes[2].plot(t, result["power"] / 1000.0, color="tab:red")
    axes[2].set_ylabel("DC power [kW]")
    axes[3].plot(t, result["voltage"], color="tab:orange")
    axes[3].set_ylabel("voltage [V]")
    axes[4].plot(t, result["h2Flow"], color="tab:green")
    axes[4].set_ylabel("H$_2$ flow [Nl/h]")
    axes[4].set_xlabel("time [min]")
    fig.suptitle("AEM electrolyser module (FMU in fmpy): setpoint step schedule")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    cli.add_out_option(parser, "out", "step_schedule.csv and step_schedule.png")
    args = parser.parse_args(argv)
    require("plots", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    csv_path, png_path = (cli.writable_folder(args.out) / f"step_schedule{suffix}" for suffix in (".csv", ".png"))
    result = simulate(args.fmu)
    write_csv(result, csv_path)
    plot(result, png_path)
    if args.quiet:
        return

    print(
        f"{'t [s]':>7} {'setpoint [%]':>12} {'current [A]':>11} {'voltage [V]':>11} {'power [W]':>10} {'H2 [Nl/h]':>9}"
    )
    times = sorted({t for t, _ in SCHEDULE} | {t + d for t, _ in SCHEDULE for d in (10, 60)} | {STOP_TIME})
    for t in times:
        if t > STOP_TIME:
            continue
        r = result[int(round(t))]
        print(
            f"{r['time']:7.0f} {r['setpoint']:12.1f} {r['current']:11.3f} {r['voltage']:11.3f} {r['power']:10.1f} {r['h2Flow']:9.1f}"
        )
    last = result[-1]
    print(f"energy {last['energy'] / 3.6e6:.4f} kWh, hydrogen {last['h2Produced']:.1f} Nl in {STOP_TIME:.0f} s")
    print(f"wrote {csv_path} and {png_path}")


if __name__ == "__main__":
    cli.run_command(main)
