#!/usr/bin/env python3
"""Example 5: a generator trips in TOPS's two-area system; the hub offers FCR-D up.

    python -m aem_electrolyser.examples.generator_trip [--duration 60] [--trip-time 2] [--capacity 12] [--load 0.8]
                                      [--modules 25000] [--band 10] [--out out]

Power system: the one of aem_electrolyser.examples.grid_cosim (its `power_system`: TOPS's Kundur two-area
system tops.ps_models.k2a, four 900 MVA generators with TGOV1 governors of 5 % droop, SEXS
voltage regulators and PSSs, 2.7 GW of constant-impedance load, and bus B12, 20 km from B9,
where the hub connects through TOPS's grid-following VSC model), without the wind farm. The
hub (25 000 modules, equal dispatch, powerInput = true) draws a constant powerReference of 80 %
of its rated power (`--load`: 46.90 MW of 58.63 MW, every module at setpoint 82.7 %), a usual
operating point that leaves room both ways; its FCR-D up capacity (`--capacity`, 12 MW) fits
the window below it: at 60 % the hub draws 32.56 MW, 14.34 MW less. The hub's power is taken
off k2a's load L2 at B9 (the hub is part of that load), so the generators keep k2a's dispatch
whatever the hub's size. The hub's VSC filters the bus angle with 20 ms instead of
grid_cosim's 0.1 s: TOPS's VSC controls its power in the frame of that filter, which lags the
bus angle by 2 pi * (f - 50 Hz) * T_pll while the frequency is off, so with 0.1 s it would
draw 1.8 % less than its setpoint at 49.7 Hz (0.07 % with 20 ms).

Event: TOPS has no generator trip (its events are line outages and admittance changes), and
the loss of one of k2a's 700 MW units would ask for more than the three others can give
(their governors stop at 900 MW: 581 MW of headroom). So G1 is written as two identical
parallel units of 450 MVA and 350 MW (TOPS's `N_par` = 2: the load flow and every trajectory
are those of k2a's single 900 MVA unit), and one of them trips at `--trip-time`: its current
injection and its admittance leave the network at once (N_par 2 -> 1, and the unit's
admittance taken off through TOPS's `y_bus_red_mod`, as in TOPS's short-circuit examples).
350 MW is 13 % of the load, a large event for a system whose governors (5 % droop on the
3150 MVA left) give 1261 MW/Hz: the frequency dips by about 270 mHz within a second, recovers
a little, then sinks further for tens of seconds as the voltage regulators (transient gain
reduction over T_b = 10 s) restore the voltages and k2a's impedance loads draw more with
them. The lowest frequency comes at the end of the run, about 305 mHz down, inside FCR-D's
49.9...49.5 Hz band. (A large load step, the other way to reach that band, would be an
impedance whose power depends on the voltage it pulls down, so its size in MW is not what
the generators see.)

Coupling (as aem_electrolyser.examples.grid_cosim): TOPS steps by 5 ms (modified Euler); every exchange
interval (0.1 s) the hub FMU's power at that instant becomes the hub VSC's setpoint, the
frequency at B12 measured by a PLL (TOPS's PLL1, 50 ms filter; f = 50 Hz * (1 + its per-unit
deviation)) becomes the FMU's `frequency` input, and the FMU steps, both held over the
interval. The hub FMU starts in steady state and its hubPower is the VSC's setpoint in TOPS's
load flow, so the system is in equilibrium before the trip. The trip comes right after the
exchange at its instant. It shifts the bus voltage angles at once, which the PLL reads as a
frequency spike at B12 (-34 mHz, decaying with the PLL's 50 ms) that stays above 49.9 Hz.

Five runs: no reserve (capacities 0), FCR-D up (fcrDUpCapacity = C: the hub draws
C * clamp((49.9 - f)/0.4, 0, 1) less), the same with reserveCompensation = true (the
current follows K/(tau_p1 s + 1), tau_p1 = 2 s, instead of 84 % on tau_p1 and the rest on
tau_p2 = 114 s), and the same with the reserve control that sells the most upward FCR-D
(reserveFilterZero = 79.2 s, the zero aem-prequalify --optimise finds for the paper's module at
80 % baseline: 69 % on tau_p1, a slower response than plain droop that the stability
requirement allows more of), and the same with the control and dispatch that sell the most
upward FCR-D together (the fewest modules, 20 000 at maxSetpoint under target dispatch, the
others idle, with reserveFilterZero = 68.4 s). Per run: the first dip (lowest frequency at B12 within 5 s of the trip), the
nadir (lowest of the run), the largest RoCoF (steepest fall over any 500 ms window, divided by
0.5 s), the settling time (from the trip until the frequency stays within +-`--band` mHz,
default 10, of its final value, the mean of the last second) and the hub's power before, 7.5 s
after the trip and at the end. 12 MW against 1261 MW/Hz can lift the frequency by a few mHz
at most, and the hub's 2 s response comes after the first dip: the table shows how little,
and `--modules 250000 --capacity 120` a hub ten times larger (469 MW of L2's 1767 MW). Writes
<out>/generator_trip.csv (every TOPS step), generator_trip_table.csv and .png before the table; the
FMU's and TOPS's messages go to stderr.
"""

import contextlib
import csv
import sys
from pathlib import Path

import numpy as np

from aem_electrolyser.examples.grid_cosim import N_MODULES, whole_tops_steps, power_system as grid_power_system
from aem_electrolyser.hub.driver import HubFMU
from aem_electrolyser.examples.wind_hub import module_rating
from aem_electrolyser.extras import require
from aem_electrolyser import cli

F_N = 50.0  # Hz
TRIP_GEN = "G1"  # split into two parallel units, one of which trips
HUB_LOAD = "L2"  # k2a's load at B9, next to B12: the hub's power is taken off it
VSC_T_PLL = 0.02  # s: the hub VSC's angle filter (grid_cosim: 0.1 s); see the docstring
ROCOF_WINDOW = 0.5  # s
FIRST_DIP_WINDOW = 5.0  # s after the trip
T_COMPARE = 7.5  # s after the trip: hub power of the plain and compensated runs
#: The zero of the reserve control that sells the most upward FCR-D at 80 % baseline [s]
#: (aem-prequalify --optimise with Table I; docs/grid-services.md).
FILTER_ZERO = 79.2
#: The control and dispatch that sell the most upward FCR-D at 80 % baseline together: the
#: fewest modules, each at maxSetpoint (target dispatch at 100 %: 20 000 of 25 000 run, the
#: others idle), with the zero at 68.4 s (python -m aem_electrolyser.reserves.operating_table,
#: its "both" column; 36.8 % of rated against 6.2 % with plain droop and equal dispatch).
BOTH_ZERO, BOTH_TARGET = 68.4, 100.0
RUNS = {  # name: (offers FCR-D up, reserveCompensation, reserveFilterZero [s], dispatchTargetSetpoint [%] or None: equal)
    "no reserve": (False, False, 0.0, None),
    "FCR-D up": (True, False, 0.0, None),
    "FCR-D up, compensated": (True, True, 0.0, None),
    "FCR-D up, zero 79 s": (True, False, FILTER_ZERO, None),
    "FCR-D up, zero 68 s, fewest modules": (True, False, BOTH_ZERO, BOTH_TARGET),
}
TABLE_HEADER = [
    "run",
    "FCR-D up capacity [MW]",
    "first dip [Hz]",
    "first dip at [s]",
    "nadir [Hz]",
    "max RoCoF [Hz/s]",
    "settling time [s]",
    "final frequency [Hz]",
    "hub power before [MW]",
    "hub power at trip + 7.5 s [MW]",
    "hub power at end [MW]",
    "reserveRequest at end [MW]",
]


def power_system(p_hub_mw, trip_gen=TRIP_GEN):
    """grid_cosim's k2a with bus B12, without the wind farm; the hub's power taken off load L2 at
    B9 (the generators keep k2a's dispatch for any hub size); trip_gen as two parallel half units."""
    model = grid_power_system(0.0, p_hub_mw)
    header, *rows = model["vsc"]["VSC"]
    t_pll = header.index("T_pll")
    model["vsc"]["VSC"] = [header] + [r[:t_pll] + [VSC_T_PLL] + r[t_pll + 1 :] for r in rows if r[0] != "WIND"]
    header, *loads = model["loads"]
    p = header.index("P")
    if not p_hub_mw < next(ld[p] for ld in loads if ld[0] == HUB_LOAD):
        raise ValueError(f"a hub of {p_hub_mw:.0f} MW does not fit into load {HUB_LOAD}")
    model["loads"] = [header] + [ld[:p] + [ld[p] - p_hub_mw] + ld[p + 1 :] if ld[0] == HUB_LOAD else ld for ld in loads]
    header, *gens = model["generators"]["GEN"]
    s_n, p = header.index("S_n"), header.index("P")
    split = []
    for g in gens:
        g = list(g)
        if g[0] == trip_gen:
            g[s_n], g[p] = g[s_n] / 2, g[p] / 2
        split.append(g + [2 if g[0] == trip_gen else 1])
    model["generators"]["GEN"] = [header + ["N_par"]] + split
    return model


def trip_one_unit(ps, x, v, gen_name=TRIP_GEN):
    """Disconnect one of the parallel units of gen_name: its current injection (scaled by N_par)
    and its admittance (through y_bus_red_mod) leave the network. Returns the unit's electric
    power [MW] just before."""
    import scipy.sparse as sp

    gen = ps.gen["GEN"]
    k = list(gen.par["name"]).index(gen_name)
    p_unit = gen.P_e(x, v)[k]
    y, _ = gen.dyn_const_adm()  # N_par units' admittances, system pu
    b = gen.bus_idx_red["terminal"][k]
    n = ps.y_bus_red_mod.shape[0]
    ps.y_bus_red_mod = ps.y_bus_red_mod + sp.csr_matrix(([-y[k] / gen.par["N_par"][k]], ([b], [b])), shape=(n, n))
    gen.par["N_par"][k] -= 1
    return p_unit


def hub_rating(fmu, n_modules, hub_factory=HubFMU):
    """(minimum, maximum) steady power [W] of the hub from the FMU's module parameters."""
    hub = hub_factory(fmu, instance_name="hub_rating", nModules=n_modules, powerInput=True)
    try:
        hub.initialize(powerReference=0.0)
        low, high = module_rating(hub)
    finally:
        hub.close()
    return n_modules * low, n_modules * high


def run_case(
    fmu,
    duration,
    p_ref,
    capacity,
    compensation,
    trip_time=2.0,
    exchange=0.1,
    dt=5e-3,
    n_modules=N_MODULES,
    hub_factory=HubFMU,
    name="hub",
    bar=None,
    filter_zero=0.0,
    dispatch_target=None,
):
    """One co-simulation; returns a dict of arrays sampled at every TOPS step (after the step);
    `bar` (tqdm) advances by the simulated seconds; `filter_zero` > 0: the reserve control's
    zero [s] (reserveFilterZero); `dispatch_target` [%]: target dispatch at that setpoint (the
    modules not running idle), else equal dispatch."""
    import tops.dynamic as dps
    import tops.solvers as dps_sol

    hub = hub_factory(
        fmu,
        instance_name=name,
        nModules=n_modules,
        powerInput=True,
        dispatch=1 if dispatch_target is None else 4,
        belowMinimum=0 if dispatch_target is None else 1,
        **({} if dispatch_target is None else {"dispatchTargetSetpoint": dispatch_target}),
        fcrDUpCapacity=capacity,
        reserveCompensation=compensation,
        **({"reserveFilterZero": filter_zero} if filter_zero > 0 else {}),
    )
    try:
        hub.initialize(powerReference=p_ref, frequency=F_N)
        p_hub = hub.get("hubPower")
        ps = dps.PowerSystemModel(model=power_system(p_hub / 1e6))
        ps.init_dyn_sim()
        sol = dps_sol.ModifiedEulerDAE(
            ps.state_derivatives, ps.solve_algebraic, 0, ps.x_0.copy(), duration, max_step=dt
        )
        vsc, pll, gen = ps.vsc["VSC"], ps.pll["PLL1"], ps.gen["GEN"]
        steps_per_exchange = int(round(exchange / dt))
        loads, lines, trafos = ps.loads["Load"], ps.lines["Line"], ps.trafos["Trafo"]
        rec = {k: [] for k in ("time", "f", "f_coi", "f_hub", "request", "hub", "vsc_hub", "gen", "loads", "losses")}
        tripped_mw = None
        k = 0
        while sol.t < duration - dt / 2:
            if k % steps_per_exchange == 0:
                f_hub = F_N * (1.0 + pll.freq_est(sol.x, sol.v)[0])  # the PLL at B12, held over the interval
                p_hub = hub.get("hubPower")  # the hub's power at t, held likewise
                vsc.set_input("P_setp", -p_hub / 1e6, 0)
                hub.set(frequency=f_hub)
                request = hub.get("reserveRequest")
                hub.step(exchange, powerReference=p_ref)
                if bar is not None:
                    bar.update(exchange)
            if tripped_mw is None and sol.t >= trip_time - dt / 2:
                tripped_mw = trip_one_unit(ps, sol.x, sol.v)
                sol.v[:] = ps.solve_algebraic(sol.t, sol.x)  # the network right after the trip
            sol.step()
            k += 1
            x, v = sol.y, sol.v
            h = gen.par["H"] * gen.par["S_n"] * gen.par["N_par"]  # the units still connected
            rec["time"].append(sol.t)
            rec["f"].append(F_N * (1.0 + pll.freq_est(x, v)[0]))
            rec["f_coi"].append(F_N * (1.0 + np.dot(h, gen.speed(x, v)) / h.sum()))
            rec["f_hub"].append(f_hub)
            rec["request"].append(request)
            rec["hub"].append(p_hub)
            b, i_vsc = vsc.current_injections(x, v)  # the VSC's current into the network
            rec["vsc_hub"].append(-(v[b[0]] * np.conj(i_vsc[0])).real * ps.s_n * 1e6)
            rec["gen"].append(np.dot(gen.P_e(x, v), gen.par["N_par"]) * 1e6)
            rec["loads"].append(loads.P(x, v).sum() * 1e6)
            rec["losses"].append((lines.p_loss_tot(x, v) + trafos.p_loss_tot(x, v)) * ps.s_n * 1e6)
    finally:
        hub.close()
    out = {k: np.array(val) for k, val in rec.items()}
    out.update(
        p_ref=p_ref,
        capacity=capacity,
        compensation=compensation,
        filter_zero=filter_zero,
        dispatch_target=dispatch_target,
        trip_time=trip_time,
        tripped=tripped_mw * 1e6 if tripped_mw is not None else 0.0,
    )
    return out


def metrics(o, band=0.010, window=ROCOF_WINDOW):
    """Frequency nadir, first dip, RoCoF, settling time and hub power of one run."""
    t, f, t0 = o["time"], o["f"], o["trip_time"]
    after = t >= t0
    dip = after & (t <= t0 + FIRST_DIP_WINDOW)
    i_dip = np.flatnonzero(dip)[np.argmin(f[dip])]
    n = int(round(window / (t[1] - t[0])))
    rocof = np.min(f[n:] - f[:-n]) / window
    final = f[t > t[-1] - 1.0].mean()
    outside = np.flatnonzero(after & (np.abs(f - final) > band))
    if outside.size == 0:
        settle = 0.0
    else:
        settle = t[outside[-1] + 1] - t0 if outside[-1] + 1 < len(t) else np.nan
    at = min(np.searchsorted(t, t0 + T_COMPARE + (t[1] - t[0]) / 2), len(t) - 1)  # holds the power at t0 + 7.5 s
    return {
        "first dip [Hz]": f[i_dip],
        "first dip at [s]": t[i_dip] - t0,
        "nadir [Hz]": f.min(),
        "max RoCoF [Hz/s]": rocof,
        "settling time [s]": settle,
        "final frequency [Hz]": final,
        "hub power before [MW]": o["hub"][0] / 1e6,
        "hub power at trip + 7.5 s [MW]": o["hub"][at] / 1e6,
        "hub power at end [MW]": o["hub"][-1] / 1e6,
        "reserveRequest at end [MW]": o["request"][-1] / 1e6,
    }


COLUMNS = [
    ("frequency at B12 [Hz]", "f"),
    ("centre-of-inertia frequency [Hz]", "f_coi"),
    ("frequency given to the hub [Hz]", "f_hub"),
    ("reserveRequest [W]", "request"),
    ("hub power (FMU) [W]", "hub"),
    ("hub power drawn by its VSC [W]", "vsc_hub"),
    ("generators' electric power [W]", "gen"),
    ("loads' power [W]", "loads"),
    ("network losses [W]", "losses"),
]


def write_csvs(out, cases, table):
    names = list(cases)
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time [s]"] + [f"{c} {label}" for c in names for label, _ in COLUMNS])
        t = cases[names[0]]["time"]
        for k in range(len(t)):
            row = [t[k]] + [cases[c][key][k] for c in names for _, key in COLUMNS]
            w.writerow([f"{x:.10g}" for x in row])
    with open(out.parent / f"{out.name}_table.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TABLE_HEADER)
        w.writerows(
            [
                [name, f"{cases[name]['capacity'] / 1e6:.10g}"] + [f"{row[h]:.10g}" for h in TABLE_HEADER[2:]]
                for name, row in table.items()
            ]
        )


def plot(path, cases, n_modules):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = dict(zip(RUNS, ["tab:gray", "tab:blue", "tab:red", "tab:green", "tab:purple"]))
    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    base = cases["no reserve"]
    for name, o in cases.items():
        t = o["time"] - o["trip_time"]
        ax[0].plot(t, o["f"], color=colors[name], label=name)
        ax[1].plot(t, 1e3 * (o["f"] - base["f"]), color=colors[name], label=name)
        ax[2].plot(t, o["hub"] / 1e6, color=colors[name], label=name)
        ax[3].plot(t, o["request"] / 1e6, color=colors[name], label=name)
    ax[0].plot(
        base["time"] - base["trip_time"],
        base["f_coi"],
        color="k",
        ls=":",
        lw=0.8,
        label="no reserve, centre of inertia",
    )
    plain = cases["FCR-D up"]
    ax[2].plot(
        plain["time"] - plain["trip_time"],
        (plain["p_ref"] + plain["request"]) / 1e6,
        color="k",
        ls=":",
        lw=0.8,
        label="asked: powerReference + reserveRequest",
    )
    ax[0].axhspan(49.5, 49.9, color="tab:orange", alpha=0.08, label="FCR-D up band 49.9…49.5 Hz")
    ax[0].set_ylim(min(base["f"].min(), 49.65) - 0.02, 50.02)
    ax[0].set_ylabel("frequency at B12 [Hz]")
    ax[1].set_ylabel("frequency gain over\nno reserve [mHz]")
    ax[2].set_ylabel("hub power [MW]")
    ax[3].set_ylabel("reserveRequest [MW]")
    ax[3].set_xlabel(f"time since the trip of a {base['tripped'] / 1e6:.0f} MW unit [s]")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    cap = max(o["capacity"] for o in cases.values())
    fig.suptitle(f"{n_modules} AEM modules offering {cap / 1e6:.3g} MW of FCR-D up in TOPS's two-area system")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def print_table(table, band):
    print(
        f"frequency at B12; RoCoF over {1e3 * ROCOF_WINDOW:.0f} ms windows; settled within ±{1e3 * band:.0f} mHz "
        f"of the final value (mean of the last second)"
    )
    print(
        f"{'run':>22} | {'first dip':>14} | {'nadir':>9} | {'RoCoF':>10} | {'settles':>7} | {'final':>9} | "
        f"{'hub before / +7.5 s / end':>25} | {'request':>7}"
    )
    for name, m in table.items():
        print(
            f"{name:>22} | {m['first dip [Hz]']:7.4f} Hz {m['first dip at [s]']:3.1f} s | "
            f"{m['nadir [Hz]']:.4f} Hz | {m['max RoCoF [Hz/s]']:.3f} Hz/s | {m['settling time [s]']:5.1f} s | "
            f"{m['final frequency [Hz]']:.4f} Hz | {m['hub power before [MW]']:5.2f} / "
            f"{m['hub power at trip + 7.5 s [MW]']:5.2f} / {m['hub power at end [MW]']:5.2f} MW | "
            f"{m['reserveRequest at end [MW]']:5.2f} MW"
        )


def run(
    fmu=None,
    duration=60.0,
    trip_time=2.0,
    capacity=12e6,
    load=0.8,
    band=0.010,
    exchange=0.1,
    n_modules=N_MODULES,
    out=None,
    hub_factory=HubFMU,
    verbose=True,
    quiet=True,
):
    """The runs of RUNS; writes generator_trip.csv, generator_trip_table.csv and .png into the
    folder `out` when given; a progress bar of simulated seconds unless quiet."""
    with (
        contextlib.redirect_stdout(sys.stderr),
        cli.progress(total=len(RUNS) * duration, unit="s", desc="generator_trip", quiet=quiet) as bar,
    ):
        # TOPS's messages are no report
        p_ref = load * hub_rating(fmu, n_modules, hub_factory)[1]
        cases = {
            name: run_case(
                fmu,
                duration,
                p_ref,
                capacity if offers else 0.0,
                compensation,
                trip_time,
                exchange,
                n_modules=n_modules,
                hub_factory=hub_factory,
                name="hub_" + name.replace(" ", "_").replace(",", ""),
                bar=bar,
                filter_zero=zero,
                dispatch_target=target,
            )
            for name, (offers, compensation, zero, target) in RUNS.items()
        }
    table = {name: metrics(o, band) for name, o in cases.items()}
    if out is not None:
        out = Path(out) / "generator_trip"
        out.parent.mkdir(parents=True, exist_ok=True)
        write_csvs(out, cases, table)
        plot(out.with_suffix(".png"), cases, n_modules)
    if verbose:
        o = cases["no reserve"]
        print(
            f"trip of one {TRIP_GEN} unit ({o['tripped'] / 1e6:.1f} MW) at t = {trip_time:g} s; hub of {n_modules} "
            f"modules at {p_ref / 1e6:.2f} MW ({100 * load:g} % of rated), FCR-D up {capacity / 1e6:g} MW"
        )
        print_table(table, band)
        if out is not None:
            table_csv = out.parent / f"{out.name}_table.csv"
            print(f"wrote {out.with_suffix('.csv')}, {table_csv} and {out.with_suffix('.png')}")
    return cases, table


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    parser.add_argument("--duration", type=cli.positive(float), default=60.0, help="simulated seconds [default: 60]")
    parser.add_argument("--trip-time", type=cli.non_negative(float), default=2.0, help="seconds [default: 2]")
    parser.add_argument(
        "--capacity", type=cli.non_negative(float), default=12.0, help="FCR-D up capacity [MW] [default: 12]"
    )
    parser.add_argument(
        "--load",
        type=cli.positive(float),
        default=0.8,
        help="hub power reference / rated power, in (0, 1] [default: 0.8]",
    )
    parser.add_argument(
        "--modules", type=cli.positive(int), default=N_MODULES, help=f"modules in the hub [default: {N_MODULES}]"
    )
    parser.add_argument("--band", type=cli.positive(float), default=10.0, help="settling band [mHz] [default: 10]")
    parser.add_argument(
        "--exchange",
        type=cli.positive(float),
        default=0.1,
        help="FMU communication step [s], a multiple of TOPS's 5 ms [default: 0.1]",
    )
    cli.add_out_option(parser, "out", "generator_trip.csv, generator_trip_table.csv and generator_trip.png")
    args = parser.parse_args(argv)
    if not args.trip_time + max(FIRST_DIP_WINDOW, T_COMPARE) < args.duration:
        parser.error(
            f"--duration: {args.duration:g} s; it must exceed --trip-time + {max(FIRST_DIP_WINDOW, T_COMPARE):g} s"
        )
    if args.load > 1:
        parser.error(f"--load: {args.load:g} is above 1 (the hub's rated power)")
    if not whole_tops_steps(args.exchange):
        parser.error(f"--exchange: {args.exchange:g} s is not a multiple of TOPS's 5 ms step")
    require("grid", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    cli.writable_folder(args.out)
    run(
        args.fmu,
        args.duration,
        args.trip_time,
        args.capacity * 1e6,
        args.load,
        args.band * 1e-3,
        args.exchange,
        args.modules,
        args.out,
        verbose=not args.quiet,
        quiet=args.quiet,
    )


if __name__ == "__main__":
    cli.run_command(main)
