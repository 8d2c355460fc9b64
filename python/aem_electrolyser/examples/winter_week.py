#!/usr/bin/env python3
"""Demo: a winter week of a wind-following hub of AEM modules, with the stack temperature, cold
and warm starts, the power supplies' losses and the auxiliaries, against the paper's model.

    python -m aem_electrolyser.examples.winter_week [--modules 40] [--days 7] [--seed 1] [--out out]

A wind farm's power (aem_electrolyser.wind.year, seeded, 60 s) scaled to 120 % of the hub's
rated stack power is the hub's power reference; sequential dispatch, the other modules in standby
for up to six hours, then off. The same wind drives three hubs, each an FMU in fmpy with 60 s
steps:

* paper: the paper's model: every stack at 55 °C, the reference is stack power;
* plant: every stack's temperature modelled (15 °C to start, cooling toward the winter air when
  stopped, cold or warm starts by temperature), and the grid side of the model page's worked
  example (auxiliaries 150 W, supply losses 30 W + 0.6 V·I + 15 mΩ·I²), the reference meant
  on the grid side (what the hub draws from the grid);
* heated: the plant with a 300 W standby heater in every module.

The winter air (an assumption, a Nordic coast in January): −2 °C mean, ±4 K a day, coldest
at 03:00. Writes <out>/winter_week.csv (every step) and winter_week.png, then prints per hub
the hydrogen, the grid energy and its part in losses and auxiliaries, the specific energy on
the grid side against the stack's, and the cold and warm starts.
"""

import csv

import numpy as np
from fmpy import read_model_description

from aem_electrolyser import cli
from aem_electrolyser.extras import require
from aem_electrolyser.hub.driver import HubFMU
from aem_electrolyser.hub.units import kg_per_nl
from aem_electrolyser.wind.year import FARM_RATING, farm_power_year

KELVIN = 273.15
STEP = 60.0
DAY = 86400.0
#: The hub's reference is the farm's power scaled to this share of the hub's rated power.
WIND_SHARE = 1.2
#: The worked example of the model page (docs/model.md): assumed supply and auxiliaries.
GRID_SIDE = {
    "auxiliaryPower": 150.0,
    "supplyNoLoadLoss": 30.0,
    "supplyLossVoltage": 0.6,
    "supplyLossResistance": 0.015,
    "gridSideReference": True,
}
HUB = {"dispatch": 2, "belowMinimum": 1, "powerInput": True, "standbyDuration": 6 * 3600.0}
VARIANTS = {
    "paper": {},
    "plant": {"thermalModel": True, **GRID_SIDE},
    "heated": {"thermalModel": True, **GRID_SIDE, "standbyHeaterPower": 300.0},
}
OUTPUTS = [
    "hubAcPower",
    "hubAcEnergy",
    "hubEnergy",
    "hubH2Produced",
    "stackTemperature",
    "modulesRunning",
    "starts",
    "warmStarts",
]


def ambient(t):
    """Winter air [K] at time t [s] from midnight: −2 °C ± 4 K, coldest at 03:00."""
    return KELVIN - 2.0 + 4.0 * np.sin(2.0 * np.pi * (np.asarray(t) / DAY - 9.0 / 24.0))


def module_rating(fmu):
    """One module's steady stack power at maxSetpoint [W], from the FMU's start values."""
    start = {v.name: v.start for v in read_model_description(str(fmu)).modelVariables}
    k, v0, r, smax = (float(start[n]) for n in ("gain", "voltageIntercept", "ohmicResistance", "maxSetpoint"))
    return (v0 + r * k * smax) * k * smax


def simulate(fmu, name, reference, modules, bar=None):
    """One hub over the week: the outputs at every step's end (first row: t = 0)."""
    n = len(reference)
    times = np.arange(n + 1) * STEP
    start = {"initialTemperature": 288.15} if VARIANTS[name].get("thermalModel") else {}
    out = {k: np.empty(n + 1) for k in OUTPUTS}
    with HubFMU(fmu, instance_name=f"winter_{name}", nModules=modules, **HUB, **VARIANTS[name], **start) as hub:
        hub.initialize(powerReference=reference[0], ambientTemperature=float(ambient(0.0)))
        for k in range(n + 1):
            for key, value in zip(OUTPUTS, hub.get(*OUTPUTS)):
                out[key][k] = value
            if k < n:
                hub.step(STEP, powerReference=reference[k], ambientTemperature=float(ambient(times[k])))
                if bar is not None:
                    bar.update(STEP)
    return out


def kpis(out, kg):
    """The week's totals of one hub (keys with units); `kg` per normal litre of hydrogen."""
    hydrogen = (out["hubH2Produced"][-1] - out["hubH2Produced"][0]) * kg
    grid = out["hubAcEnergy"][-1] - out["hubAcEnergy"][0]
    stack = out["hubEnergy"][-1] - out["hubEnergy"][0]
    starts = out["starts"][-1] - out["starts"][0]
    warm = out["warmStarts"][-1] - out["warmStarts"][0]
    return {
        "hydrogen [kg]": hydrogen,
        "grid energy [MWh]": grid / 3.6e9,
        "supply losses and auxiliaries [MWh]": (grid - stack) / 3.6e9,
        "specific energy, grid side [kWh/kg]": grid / 3.6e6 / hydrogen if hydrogen > 0 else float("nan"),
        "specific energy, electric [kWh/kg]": stack / 3.6e6 / hydrogen if hydrogen > 0 else float("nan"),
        "cold starts [1]": starts - warm,
        "warm starts [1]": warm,
    }


def write_csv(reference, runs, path):
    times = np.arange(len(reference) + 1) * STEP
    header = ["time [h]", "wind reference [kW]", "ambient temperature [degC]"]
    for name in runs:
        header += [f"{name} grid power [kW]", f"{name} mean stack temperature [degC]", f"{name} modules running [1]"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for k, t in enumerate(times):
            row = [t / 3600.0, reference[min(k, len(reference) - 1)] / 1e3, float(ambient(t)) - KELVIN]
            for out in runs.values():
                row += [out["hubAcPower"][k] / 1e3, out["stackTemperature"][k] - KELVIN, out["modulesRunning"][k]]
            w.writerow([f"{x:.8g}" for x in row])


def plot(reference, runs, path, kg):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    days = np.arange(len(reference) + 1) * STEP / DAY
    colours = {"paper": "tab:blue", "plant": "tab:orange", "heated": "tab:red"}
    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    axes[0].step(days[:-1], reference / 1e3, where="post", color="tab:gray", lw=0.8, label="wind reference")
    for name, out in runs.items():
        axes[0].plot(days, out["hubAcPower"] / 1e3, color=colours[name], lw=0.8, label=f"{name}: from the grid")
        axes[2].plot(days, out["modulesRunning"], color=colours[name], lw=0.8, label=name)
        axes[3].plot(days, (out["hubH2Produced"] - out["hubH2Produced"][0]) * kg, color=colours[name], label=name)
        if name != "paper":
            axes[1].plot(
                days, out["stackTemperature"] - KELVIN, color=colours[name], lw=0.8, label=f"{name}: mean stack"
            )
    axes[1].plot(days, ambient(days * DAY) - KELVIN, color="tab:gray", lw=0.8, label="winter air")
    axes[1].axhline(55.0, color="tab:blue", ls=":", lw=0.8, label="paper: 55 °C throughout")
    axes[0].set_ylabel("power [kW]")
    axes[1].set_ylabel("temperature [°C]")
    axes[2].set_ylabel("modules running")
    axes[3].set_ylabel("hydrogen [kg]")
    axes[3].set_xlabel("time [days]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    fig.suptitle("A winter week of a wind-following AEM hub (FMU in fmpy)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def reference_power(days, seed, modules, rating):
    """The farm's power at 60 s, scaled to WIND_SHARE of the hub's rated power [W]."""
    farm = farm_power_year(days * DAY, dt=STEP, seed=seed, threads=1)
    return farm / FARM_RATING * WIND_SHARE * modules * rating


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    parser.add_argument("--modules", type=cli.positive(int), default=40, help="modules in the hub [default: 40]")
    parser.add_argument("--days", type=cli.positive(float), default=7.0, help="simulated days [default: 7]")
    parser.add_argument("--seed", type=int, default=1, help="seed of the wind [default: 1]")
    cli.add_out_option(parser, "out", "winter_week.csv and winter_week.png")
    args = parser.parse_args(argv)
    if args.days * DAY < 2 * STEP:
        parser.error(f"--days: {args.days:g} is shorter than two 60 s steps")
    require("plots", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    csv_path, png_path = (cli.writable_folder(args.out) / f"winter_week{suffix}" for suffix in (".csv", ".png"))
    reference = reference_power(args.days, args.seed, args.modules, module_rating(args.fmu))
    runs = {}
    with cli.progress(
        total=len(VARIANTS) * len(reference) * STEP, desc="winter week", unit="s", quiet=args.quiet
    ) as bar:
        for name in VARIANTS:
            runs[name] = simulate(args.fmu, name, reference, args.modules, bar=bar)
    write_csv(reference, runs, csv_path)
    kg = kg_per_nl(args.fmu)
    plot(reference, runs, png_path, kg)
    if args.quiet:
        return
    print(f"{args.modules} modules, {args.days:g} days, wind {reference.sum() * STEP / 3.6e9:.3f} MWh offered")
    table = {name: kpis(out, kg) for name, out in runs.items()}
    width = max(len(k) for k in next(iter(table.values())))
    print(f"{'':{width}}" + "".join(f"{name:>12}" for name in table))
    for key in next(iter(table.values())):
        print(f"{key:{width}}" + "".join(f"{table[name][key]:12.4g}" for name in table))
    print(f"wrote {csv_path} and {png_path}")


if __name__ == "__main__":
    cli.run_command(main)
