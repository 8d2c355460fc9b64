#!/usr/bin/env python3
"""Demo: a cold morning start of one AEM module with the stack temperature modelled, against
the paper's model (which holds the stack at 55 °C), both simulated by fmpy.

    python -m aem_electrolyser.examples.cold_start [--out out]

The module starts at dawn with its stack at the ambient 5 °C, runs at 60 % for an hour and at
100 % for two more; the ambient warms to 8 °C meanwhile. The cold stack needs a higher voltage (the
polarisation curve falls by kV per kelvin, its resistance by kR), which falls as the stack warms,
until the thermostat holds it at 55 °C. The paper's validation day shows the same: its voltage
error is largest right after a start, while the electrolyte is warming.

Writes <out>/cold_start.csv (every 10 s) and cold_start.png, then prints a summary: when the
stack reaches the setpoint, and the extra energy the cold morning costs.
"""

import csv

import numpy as np
from fmpy import read_model_description, simulate_fmu

from aem_electrolyser import cli
from aem_electrolyser.extras import require
from aem_electrolyser.hub.messages import log_to_stderr, refusal

KELVIN = 273.15
STOP_TIME = 3 * 3600.0
STEP = 10.0
#: (time [s], setpoint [%]): an hour at the bottom of the window, then full load.
SCHEDULE = [(0.0, 60.0), (3600.0, 100.0)]
#: Ambient temperature [K] at dawn and at the end (linear in between).
AMBIENT = (5.0 + KELVIN, 8.0 + KELVIN)
OUTPUTS = [
    "setpoint",
    "ambientTemperature",
    "stackTemperature",
    "current",
    "voltage",
    "power",
    "coolingPower",
    "energy",
    "h2Produced",
]


def input_signal(model_description):
    """Setpoint steps and the ambient's ramp as fmpy's structured input; the other inputs at
    their start values."""
    times = np.arange(0.0, STOP_TIME + STEP, STEP)
    setpoint = np.array([[u for t0, u in SCHEDULE if t0 <= t][-1] for t in times])
    ambient = AMBIENT[0] + (AMBIENT[1] - AMBIENT[0]) * times / STOP_TIME
    driven = {"setpoint": setpoint, "ambientTemperature": ambient}
    held = [v for v in model_description.modelVariables if v.causality == "input" and v.name not in driven]
    dtype = [("time", np.float64)] + [(n, np.float64) for n in driven] + [(v.name, np.float64) for v in held]
    rows = [(t, *(driven[n][k] for n in driven), *(float(v.start) for v in held)) for k, t in enumerate(times)]
    return np.array(rows, dtype=dtype)


def simulate(fmu, thermal):
    """The morning with the stack temperature modelled (`thermal`) or the paper's model."""
    signal = input_signal(read_model_description(str(fmu)))
    start = {"thermalModel": True, "initialTemperature": AMBIENT[0]} if thermal else {}
    try:
        return simulate_fmu(
            str(fmu),
            start_time=0.0,
            stop_time=STOP_TIME,
            step_size=STEP,
            output_interval=STEP,
            input=signal,
            start_values=start,
            output=OUTPUTS,
            logger=log_to_stderr,
        )
    except Exception as e:  # noqa: BLE001 - fmpy raises plain Exceptions
        raise refusal(f"the simulation ({e})") from None


HEADER = [
    "time [s]",
    "setpoint [%]",
    "ambient temperature [degC]",
    "stack temperature [degC]",
    "current [A]",
    "voltage [V]",
    "voltage at 55 degC [V]",
    "power [W]",
    "power at 55 degC [W]",
    "cooling power [W]",
    "energy [J]",
    "energy at 55 degC [J]",
    "hydrogen [Nl]",
]


def write_csv(warm, paper, path):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(HEADER)
        for a, b in zip(warm, paper):
            row = [
                a["time"],
                a["setpoint"],
                a["ambientTemperature"] - KELVIN,
                a["stackTemperature"] - KELVIN,
                a["current"],
                a["voltage"],
                b["voltage"],
                a["power"],
                b["power"],
                a["coolingPower"],
                a["energy"],
                b["energy"],
                a["h2Produced"],
            ]
            w.writerow([f"{x:.10g}" for x in row])


def plot(warm, paper, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = warm["time"] / 3600.0
    fig, axes = plt.subplots(4, 1, figsize=(9, 9.5), sharex=True)
    axes[0].plot(t, warm["stackTemperature"] - KELVIN, color="tab:red", label="stack")
    axes[0].plot(t, warm["ambientTemperature"] - KELVIN, color="tab:gray", label="ambient")
    axes[0].axhline(55.0, color="tab:red", lw=0.8, ls=":", label="thermostat setpoint")
    axes[0].set_ylabel("temperature [°C]")
    axes[0].legend(loc="center right", fontsize=8)
    axes[1].plot(t, warm["voltage"], color="tab:orange", label="stack temperature modelled")
    axes[1].plot(t, paper["voltage"], color="tab:blue", ls="--", label="paper's model (55 °C)")
    axes[1].set_ylabel("voltage [V]")
    axes[1].legend(loc="lower right", fontsize=8)
    axes[2].plot(t, warm["power"] / 1000.0, color="tab:orange", label="stack temperature modelled")
    axes[2].plot(t, paper["power"] / 1000.0, color="tab:blue", ls="--", label="paper's model (55 °C)")
    axes[2].set_ylabel("DC power [kW]")
    axes[2].legend(loc="lower right", fontsize=8)
    axes[3].plot(t, warm["coolingPower"], color="tab:cyan")
    axes[3].set_ylabel("cooling [W]")
    axes[3].set_xlabel("time since the start [h]")
    fig.suptitle("A cold morning start of one AEM module (FMU in fmpy)")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def summary(warm, paper):
    """(hours until the stack reaches its setpoint or None, extra energy [kWh], hydrogen [Nl])."""
    reached = np.flatnonzero(warm["stackTemperature"] >= 55.0 + KELVIN - 1e-9)
    hours = warm["time"][reached[0]] / 3600.0 if reached.size else None
    extra = (warm["energy"][-1] - paper["energy"][-1]) / 3.6e6
    return hours, extra, warm["h2Produced"][-1]


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    cli.add_out_option(parser, "out", "cold_start.csv and cold_start.png")
    args = parser.parse_args(argv)
    require("plots", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    csv_path, png_path = (cli.writable_folder(args.out) / f"cold_start{suffix}" for suffix in (".csv", ".png"))
    warm, paper = simulate(args.fmu, thermal=True), simulate(args.fmu, thermal=False)
    write_csv(warm, paper, csv_path)
    plot(warm, paper, png_path)
    if args.quiet:
        return
    hours, extra, hydrogen = summary(warm, paper)
    reach = f"reaches 55 °C after {hours:.2f} h" if hours is not None else "does not reach 55 °C"
    print(f"stack from {AMBIENT[0] - KELVIN:.0f} °C: {reach}")
    print(f"start voltage {warm['voltage'][0]:.2f} V against {paper['voltage'][0]:.2f} V at 55 °C")
    print(
        f"energy {warm['energy'][-1] / 3.6e6:.3f} kWh against {paper['energy'][-1] / 3.6e6:.3f} kWh at 55 °C: "
        f"the cold morning costs {extra:.3f} kWh for the same {hydrogen:.0f} Nl of hydrogen"
    )
    print(f"wrote {csv_path} and {png_path}")


if __name__ == "__main__":
    cli.run_command(main)
