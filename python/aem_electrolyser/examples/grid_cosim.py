#!/usr/bin/env python3
"""Example 4: the electrolyser hub FMU co-simulated with the power-system simulator TOPS.

    python -m aem_electrolyser.examples.grid_cosim [--duration 60] [--gust-start 10] [--exchange 0.1] [--out out]

Power system: TOPS's Kundur two-area system (tops.ps_models.k2a: four 900 MVA generators with
governors, AVRs and PSSs, 2.7 GW of load) with one added 230 kV bus B12, 20 km of line from
B9, where a 64 MW wind farm and the 60 MW hub (25 000 modules, equal dispatch) connect. TOPS
ships no test system with a converter, so both are its grid-following VSC model
(tops.dyn_models.vsc.VSC: PLL, PI power controllers, current lag) added to k2a: the wind farm
injects P_setp = wind power, the hub draws it (negative P_setp = consumption), Q_setp = 0.

Coupling: TOPS steps by 5 ms (its modified Euler DAE solver) and sets the wind VSC's
setpoint at every step; every exchange interval (0.1 s) the wind power is the hub FMU's
powerReference, the FMU (fmpy FMU2Slave) does one step, and the hub VSC's setpoint is the
hub's power at the start of the interval (held until the next exchange). Initialisation: the hub FMU starts in steady state for the initial wind
power, its hubPower sets the hub VSC's P_setp before TOPS's load flow, so the system starts
in equilibrium (no start transient). Two runs: steady 10 m/s wind, and the same with an IEC
61400-1 extreme operating gust (aem_electrolyser.wind.farm) on every turbine at once. Frequency
and voltage at B12 (a PLL at the bus) are plotted; <out>/grid_cosim.csv and grid_cosim.png are
written before the summary is printed, and TOPS's messages go to stderr.
"""

import contextlib
import csv
import sys
from pathlib import Path

import numpy as np

from aem_electrolyser.hub.driver import HubFMU
from aem_electrolyser.wind.farm import N_TURBINES, Site, Turbine, extreme_operating_gust, power_curve
from aem_electrolyser.extras import require
from aem_electrolyser import cli

N_MODULES = 25_000
BUS, BUS_KV = "B12", 230.0
TOPS_STEP = 5e-3  # TOPS's modified Euler step [s]; the FMU exchanges at whole multiples of it


def whole_tops_steps(seconds):
    """Whether `seconds` is a whole number of TOPS steps (to 1e-9 of a step)."""
    return abs(seconds / TOPS_STEP - round(seconds / TOPS_STEP)) <= 1e-9


def power_system(p_wind_mw, p_hub_mw):
    """k2a with bus B12 carrying the wind farm's and the hub's VSCs and a PLL."""
    import tops.ps_models.k2a as k2a

    model = k2a.load()
    model["buses"].append([BUS, BUS_KV])
    model["lines"].append(["L9-12", "B9", BUS, 20, 100, BUS_KV, "p.u.", 1e-4, 1e-3, 1.75e-3])
    g = np.sqrt(3) * BUS_KV  # MW per kA at 1 pu: the PI gains below act on MW errors
    header = ["name", "T_pll", "T_i", "bus", "P_K_p", "P_K_i", "Q_K_p", "Q_K_i", "P_setp", "Q_setp"]
    model["vsc"] = {
        "VSC": [
            header,
            ["WIND", 0.1, 0.02, BUS, 0.5 / g, 10 / g, 0.5 / g, 10 / g, p_wind_mw, 0.0],
            ["HUB", 0.1, 0.02, BUS, 0.5 / g, 10 / g, 0.5 / g, 10 / g, -p_hub_mw, 0.0],
        ]
    }
    model["pll"] = {"PLL1": [["name", "T_filter", "bus"], ["PLL12", 0.05, BUS]]}
    return model


def wind_power(t, gust_start, site=Site(), turbine=Turbine()):
    """Farm power [W] at steady mean wind, plus the gust if gust_start is not None."""
    v = site.mean_speed + (0.0 if gust_start is None else extreme_operating_gust(t, gust_start, site, turbine))
    return N_TURBINES * float(power_curve(v, turbine))


def run_case(fmu, duration, gust_start, exchange=0.1, dt=5e-3, hub_factory=HubFMU, dispatch=(1, 0), bar=None):
    """One co-simulation; returns a dict of arrays sampled at every TOPS step. `bar` (tqdm)
    advances by the simulated seconds."""
    import tops.dynamic as dps
    import tops.solvers as dps_sol

    p_wind = wind_power(0.0, gust_start)
    hub = hub_factory(
        fmu,
        instance_name="hub_gust" if gust_start is not None else "hub_steady",
        nModules=N_MODULES,
        powerInput=True,
        dispatch=dispatch[0],
        belowMinimum=dispatch[1],
    )
    try:
        hub.initialize(powerReference=p_wind)
        p_hub = hub.get("hubPower")
        ps = dps.PowerSystemModel(model=power_system(p_wind / 1e6, p_hub / 1e6))
        ps.init_dyn_sim()
        sol = dps_sol.ModifiedEulerDAE(
            ps.state_derivatives, ps.solve_algebraic, 0, ps.x_0.copy(), duration, max_step=dt
        )
        vsc, pll = ps.vsc["VSC"], ps.pll["PLL1"]
        bus = vsc.bus_idx_red["terminal"][0]
        steps_per_exchange = int(round(exchange / dt))
        rec = {k: [] for k in ("time", "wind", "hub", "vsc_wind", "vsc_hub", "df", "v")}
        k = 0
        while sol.t < duration - dt / 2:
            p_wind = wind_power(sol.t, gust_start)  # the wind farm is part of the TOPS model
            vsc.set_input("P_setp", p_wind / 1e6, 0)
            if k % steps_per_exchange == 0:
                p_hub = hub.get("hubPower")  # the hub's power at t, held over the exchange
                vsc.set_input("P_setp", -p_hub / 1e6, 1)
                hub.step(exchange, powerReference=p_wind)
                if bar is not None:
                    bar.update(exchange)
            sol.step()
            k += 1
            x, v = sol.y, sol.v
            p = vsc.P(x, v)
            rec["time"].append(sol.t)
            rec["wind"].append(p_wind)
            rec["hub"].append(p_hub)
            rec["vsc_wind"].append(p[0] * 1e6)
            rec["vsc_hub"].append(-p[1] * 1e6)
            rec["df"].append(50.0 * pll.freq_est(x, v)[0])
            rec["v"].append(abs(v[bus]))
    finally:
        hub.close()
    out = {k: np.array(val) for k, val in rec.items()}
    out["v0"] = abs(ps.v_0[ps.vsc["VSC"].bus_idx["terminal"][0]])
    return out


def write_csv(path, cases):
    names = list(cases)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["time [s]"]
            + [
                f"{c} {q}"
                for c in names
                for q in (
                    "wind power [W]",
                    "hub power [W]",
                    "grid exchange [W]",
                    "frequency deviation [Hz]",
                    "voltage [pu]",
                )
            ]
        )
        t = cases[names[0]]["time"]
        for k in range(len(t)):
            row = [t[k]]
            for c in names:
                o = cases[c]
                row += [o["vsc_wind"][k], o["vsc_hub"][k], o["vsc_wind"][k] - o["vsc_hub"][k], o["df"][k], o["v"][k]]
            w.writerow([f"{x:.10g}" for x in row])


def plot(path, cases):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = {"steady wind": "tab:gray", "gust": "tab:red"}
    fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    g = cases["gust"]
    ax[0].plot(g["time"], g["vsc_wind"] / 1e6, color="tab:blue", label="wind farm")
    ax[0].plot(g["time"], g["vsc_hub"] / 1e6, color="tab:green", label="hub (consumption)")
    ax[0].plot(g["time"], (g["vsc_wind"] - g["vsc_hub"]) / 1e6, color="tab:red", label="grid exchange (+ export)")
    ax[0].set_ylabel("power at B12 [MW]\n(gust case)")
    ax[0].legend(fontsize=8)
    for name, o in cases.items():
        ax[1].plot(o["time"], 1e3 * o["df"], color=colors[name], label=name)
        ax[2].plot(o["time"], o["v"], color=colors[name], label=name)
    ax[1].set_ylabel("frequency deviation\nat B12 [mHz]")
    ax[2].set_ylabel("voltage at B12 [pu]")
    ax[2].set_xlabel("time [s]")
    for a in ax:
        a.grid(alpha=0.3)
    ax[1].legend(fontsize=8)
    fig.suptitle(f"{N_MODULES} AEM modules (FMU) and a 64 MW wind farm in TOPS's two-area system")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def run(fmu=None, duration=60.0, gust_start=10.0, exchange=0.1, out=None, hub_factory=HubFMU, verbose=True, quiet=True):
    """Both cases; writes <out>/grid_cosim.csv and .png when the folder `out` is given; a progress
    bar of simulated seconds unless quiet."""
    with (
        contextlib.redirect_stdout(sys.stderr),
        cli.progress(total=2 * duration, unit="s", desc="grid_cosim", quiet=quiet) as bar,
    ):
        # TOPS's messages are no report
        cases = {
            "steady wind": run_case(fmu, duration, None, exchange, hub_factory=hub_factory, bar=bar),
            "gust": run_case(fmu, duration, gust_start, exchange, hub_factory=hub_factory, bar=bar),
        }
    if out is not None:
        out = Path(out) / "grid_cosim"
        out.parent.mkdir(parents=True, exist_ok=True)
        write_csv(out.with_suffix(".csv"), cases)
        plot(out.with_suffix(".png"), cases)
    if verbose:
        for name, o in cases.items():
            exch = o["vsc_wind"] - o["vsc_hub"]
            print(
                f"{name:>12}: hub {o['vsc_hub'][0] / 1e6:.2f} MW at t = 0, max |grid exchange| "
                f"{np.abs(exch).max() / 1e6:6.2f} MW, max |frequency deviation| {1e3 * np.abs(o['df']).max():.3g} mHz, "
                f"voltage {o['v'].min():.5f}…{o['v'].max():.5f} pu"
            )
        if out is not None:
            print(f"wrote {out.with_suffix('.csv')} and {out.with_suffix('.png')}")
    return cases


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    parser.add_argument("--duration", type=cli.positive(float), default=60.0, help="simulated seconds [default: 60]")
    parser.add_argument(
        "--gust-start",
        type=cli.non_negative(float),
        default=10.0,
        help="start of the gust [s], before the end [default: 10]",
    )
    parser.add_argument(
        "--exchange",
        type=cli.positive(float),
        default=0.1,
        help="FMU communication step [s], a multiple of TOPS's 5 ms [default: 0.1]",
    )
    cli.add_out_option(parser, "out", "grid_cosim.csv and grid_cosim.png")
    args = parser.parse_args(argv)
    if args.gust_start >= args.duration:
        parser.error(f"--gust-start: {args.gust_start:g} s is not before the end (--duration {args.duration:g} s)")
    if not whole_tops_steps(args.exchange) or args.exchange > args.duration:
        parser.error(f"--exchange: {args.exchange:g} s is not a multiple of TOPS's 5 ms step within --duration")
    require("grid", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    cli.writable_folder(args.out)
    run(args.fmu, args.duration, args.gust_start, args.exchange, args.out, verbose=not args.quiet, quiet=args.quiet)


if __name__ == "__main__":
    cli.run_command(main)
