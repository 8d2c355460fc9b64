#!/usr/bin/env python3
"""Example 3: a 60 MW electrolyser hub (25 000 AEM modules) follows a 64 MW offshore wind farm.

    python -m aem_electrolyser.examples.wind_hub [--hours 1 | --duration SECONDS] [--seed 1] [--out out]

The wind farm's power (aem_electrolyser.wind.farm, 1 s, seeded) is the hub's power reference
(`powerInput` = true, input `powerReference` [W]); the hub FMU runs in fmpy with 1 s
communication steps, the reference held over each step. Grid exchange = wind power − hub
power (positive: export of wind power the hub did not absorb). Two dispatches side by side:
equal (every module the same share; below the minimum they stay at 60 %, the paper's
behaviour) and sequential (as few modules as possible, the others in standby). Prints the
energy not absorbed, the hydrogen produced and the RMS tracking error of each after it has
written <out>/wind_hub.csv and wind_hub.png.
"""

import contextlib
import csv
import sys
from pathlib import Path

import numpy as np

from aem_electrolyser.hub.dispatch import DISPATCHES, N_MODULES
from aem_electrolyser.hub.driver import HubFMU
from aem_electrolyser.hub.units import kg_per_nl
from aem_electrolyser.locate import fmu_path as locate_fmu
from aem_electrolyser.wind.farm import farm_power
from aem_electrolyser.extras import require
from aem_electrolyser import cli

OUTPUTS = [
    "hubPower",
    "hubEnergy",
    "hubH2Produced",
    "power",
    "modulesRunning",
    "modulesStarting",
    "modulesStandby",
    "starts",
]


def module_rating(hub):
    """(minimum, maximum) steady electric power [W] of one module from the FMU's parameters."""
    k, v0, r, smin, smax = hub.get("gain", "voltageIntercept", "ohmicResistance", "minSetpoint", "maxSetpoint")
    return tuple((v0 + r * k * s) * k * s for s in (smin, smax))


def simulate(fmu, reference, dt, dispatch, n_modules=N_MODULES, hub_factory=HubFMU, bar=None):
    """Drive the hub with reference[k] [W] over [k dt, (k+1) dt); outputs at every k dt.

    Returns a dict of arrays (len(reference) + 1 samples) and the module rating.
    """
    n = len(reference)
    hub = hub_factory(fmu, instance_name=f"hub_{dispatch}", nModules=n_modules, powerInput=True, **DISPATCHES[dispatch])
    try:
        hub.initialize(powerReference=reference[0])
        rating = module_rating(hub)
        out = {name: np.empty(n + 1) for name in OUTPUTS}
        for k in range(n + 1):
            for name, value in zip(OUTPUTS, hub.get(*OUTPUTS)):
                out[name][k] = value
            if k < n:
                hub.step(dt, powerReference=reference[k])
                if bar is not None:
                    bar.update(dt)
    finally:
        hub.close()
    return out, rating


def summarise(reference, dt, out, n_modules, rating, kg_per_nl):
    """Energies [J], hydrogen [kg] (the FMU's Nl times `kg_per_nl`) and tracking error [W] of
    one run."""
    wind_step = reference * dt  # the reference is held over each step
    hub_step = np.diff(out["hubEnergy"])  # the FMU's exact integral over each step
    grid_step = wind_step - hub_step
    err = out["hubPower"][:-1] - reference
    return dict(
        wind=wind_step.sum(),
        hub=out["hubEnergy"][-1] - out["hubEnergy"][0],
        grid=grid_step.sum(),
        exported=grid_step[grid_step > 0].sum(),
        imported=-grid_step[grid_step < 0].sum(),
        h2_kg=(out["hubH2Produced"][-1] - out["hubH2Produced"][0]) * kg_per_nl,
        rms=np.sqrt(np.mean(err**2)),
        nominal=n_modules * rating[1],
        starts=out["starts"][-1],
    )


def write_csv(path, t, wind, runs):
    names = list(runs)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["time [s]", "wind power [W]"]
            + [
                f"{d} {c}"
                for d in names
                for c in (
                    "hub power [W]",
                    "grid exchange [W]",
                    "hub energy [J]",
                    "module mean power [W]",
                    "modules running [1]",
                )
            ]
        )
        for k in range(len(t)):
            row = [t[k], wind[k]]
            for d in names:
                o = runs[d]
                row += [
                    o["hubPower"][k],
                    wind[k] - o["hubPower"][k],
                    o["hubEnergy"][k],
                    o["power"][k],
                    o["modulesRunning"][k],
                ]
            w.writerow([f"{x:.10g}" for x in row])


def plot(path, t, wind, runs, n_modules, rating):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tm = t / 60.0
    colors = {"equal": "tab:blue", "sequential": "tab:orange"}
    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    ax[0].plot(tm, wind / 1e6, color="tab:gray", lw=1, label="wind farm (reference)")
    for d, o in runs.items():
        ax[0].plot(tm, o["hubPower"] / 1e6, color=colors[d], lw=1, label=f"hub, {d} dispatch")
        ax[1].plot(tm, (wind - o["hubPower"]) / 1e6, color=colors[d], lw=1, label=d)
    ax[0].axhline(n_modules * rating[1] / 1e6, color="k", ls=":", lw=0.8, label="hub at 100 %")
    ax[0].axhline(n_modules * rating[0] / 1e6, color="k", ls="--", lw=0.8, label="all modules at 60 %")
    ax[0].set_ylim(bottom=20)  # room for the legend
    ax[0].set_ylabel("power [MW]")
    ax[0].legend(fontsize=7, ncol=3, loc="lower right")
    ax[1].axhline(0, color="k", lw=0.5)
    ax[1].set_ylabel("grid exchange [MW]\n(+ export)")
    ax[1].legend(fontsize=7)
    if "sequential" in runs:
        o = runs["sequential"]
        ax[2].plot(tm, o["modulesRunning"], color=colors["sequential"], lw=1, label="running")
        ax[2].plot(tm, o["modulesStarting"], color="tab:red", lw=1, label="starting")
        ax[2].plot(tm, o["modulesStandby"], color="tab:green", lw=1, label="standby")
        ax[2].legend(fontsize=7)
    ax[2].set_ylabel("modules, sequential [1]")
    ax[3].plot(tm, wind / n_modules, color="tab:gray", lw=1, label="reference $P_{ref}/N$")
    ax[3].plot(tm, runs["equal"]["power"], color=colors["equal"], lw=1, label="one module, equal dispatch")
    ax[3].axhspan(rating[0], rating[1], color="tab:green", alpha=0.08, label="module window 60…100 %")
    ax[3].set_ylabel("module power [W]")
    ax[3].set_xlabel("time [min]")
    ax[3].legend(fontsize=7, loc="lower right")
    for a in ax:
        a.grid(alpha=0.3)
    fig.suptitle(f"{n_modules} AEM modules following a 64 MW offshore wind farm (FMU in fmpy)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def run(
    fmu=None,
    duration=3600.0,
    seed=1,
    out=None,
    hub_factory=HubFMU,
    dispatches=tuple(DISPATCHES),
    verbose=True,
    quiet=True,
):
    """Simulate every dispatch; write <out>/wind_hub.csv and .png when the folder `out` is given;
    a progress bar of simulated seconds unless quiet."""
    dt = 1.0
    t, wind, _ = farm_power(duration + dt, dt, seed=seed)
    reference = wind[:-1]
    runs, summaries = {}, {}
    kg = kg_per_nl(locate_fmu(fmu))  # the FMU's own normal density of hydrogen
    with (
        contextlib.redirect_stdout(sys.stderr),
        cli.progress(total=len(dispatches) * len(reference) * dt, unit="s", desc="wind_hub", quiet=quiet) as bar,
    ):
        for d in dispatches:
            runs[d], rating = simulate(fmu, reference, dt, d, hub_factory=hub_factory, bar=bar)
            summaries[d] = summarise(reference, dt, runs[d], N_MODULES, rating, kg)
    if out is not None:
        out = Path(out) / "wind_hub"
        out.parent.mkdir(parents=True, exist_ok=True)
        write_csv(out.with_suffix(".csv"), t, wind, runs)
        plot(out.with_suffix(".png"), t, wind, runs, N_MODULES, rating)
    if verbose:
        s0 = next(iter(summaries.values()))
        print(
            f"wind farm: {s0['wind'] / 3.6e9:.2f} MWh in {duration:.0f} s (mean {reference.mean() / 1e6:.2f} MW); "
            f"hub of {N_MODULES} modules, {s0['nominal'] / 1e6:.2f} MW at 100 %"
        )
        print(
            f"{'dispatch':>10} {'hub [MWh]':>9} {'not absorbed [MWh]':>18} {'imported [MWh]':>14} "
            f"{'H2 [kg]':>8} {'RMS error [MW]':>14} {'[% nom]':>7} {'starts':>6}"
        )
        for d, s in summaries.items():
            print(
                f"{d:>10} {s['hub'] / 3.6e9:9.3f} {s['exported'] / 3.6e9:18.3f} {s['imported'] / 3.6e9:14.3f} "
                f"{s['h2_kg']:8.1f} {s['rms'] / 1e6:14.3f} {100 * s['rms'] / s['nominal']:7.2f} {s['starts']:6.0f}"
            )
        if out is not None:
            print(f"wrote {out.with_suffix('.csv')} and {out.with_suffix('.png')}")
    return t, wind, runs, summaries


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    span = parser.add_mutually_exclusive_group()
    span.add_argument("--hours", type=cli.positive(float), default=1.0, help="simulated hours [default: 1]")
    span.add_argument("--duration", type=cli.positive(float), help="simulated seconds (instead of --hours)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the wind series [default: 1]")
    cli.add_out_option(parser, "out", "wind_hub.csv and wind_hub.png")
    args = parser.parse_args(argv)
    duration = args.duration if args.duration else args.hours * 3600.0
    given = f"--duration: {duration:g} s" if args.duration else f"--hours: {args.hours:g} h ({duration:g} s)"
    if duration < 2.0:
        parser.error(f"{given} is shorter than two 1 s steps")
    if abs(duration - round(duration)) > 1e-9 * duration:  # the hub runs whole 1 s steps
        parser.error(f"{given} is not a whole number of the hub's 1 s steps")
    duration = float(round(duration))
    require("plots", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    cli.writable_folder(args.out)
    run(args.fmu, duration, args.seed, args.out, verbose=not args.quiet, quiet=args.quiet)


if __name__ == "__main__":
    cli.run_command(main)
