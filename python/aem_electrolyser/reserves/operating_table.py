#!/usr/bin/env python3
"""How much of each reserve product a hub sells over its base power, and which lever gives it:
plain droop, slow-pole compensation, the optimised control, the optimised dispatch, and both.

    python -m aem_electrolyser.reserves.operating_table [--modules 100]
        [--baseline 35,40,...,100] [--products "FCR-D up,FCR-D down,FCR-N,aFRR up,aFRR down"]
        [--out out/operating_table] [--no-plots]

Per baseline and product, on the packaged FMU (each capacity prequalified by aem-prequalify's
test programme and bisection):
- plain droop and compensation, each with the better of equal dispatch (where every module can
  run: from minSetpoint's share up) and sequential dispatch (the fewest modules);
- the optimised control: the zero τn in [τp1, τp2] that sells the most (aem-prequalify
  --optimise), with that reference dispatch;
- the optimised dispatch: the running count that sells the most with plain droop (--optimise-
  dispatch, target dispatch), or the reference dispatch where no count beats it;
- both: the zero optimised again at the best count (one round of coordinate search); the best
  of the control alone, the count alone and both together is reported;
- two physical bounds: the window's (up: the baseline down to every module in standby; down:
  every module at maxSetpoint) and, for downward FCR-D, the rising-current limit's: the most
  modules that can run at the baseline, each rising at rampUpLimit for the 7.5 s of full
  activation, over the 86 % the ramp test asks for.

Writes <out>/table.md, .csv, .json and, unless --no-plots, table.png (capacity in % of rated
power over the baseline, one panel per product). The percentages of a hub of N modules hold for
any hub with the same running counts per module; the default 100 modules keep it to minutes.
"""

import os
import time
from pathlib import Path

from aem_electrolyser import cli
from aem_electrolyser.hub.runner import Hub
from aem_electrolyser.reserves import dispatch_search, optimise, report
from aem_electrolyser.reserves.prequalify import (
    BELOW_MINIMUM,
    BY_NAME,
    baselines,
    modules_count,
    percent,
    Jobs,
    time_constants,
)

DEFAULT_PRODUCTS = ["FCR-D up", "FCR-D down", "FCR-N", "aFRR up", "aFRR down"]
DEFAULT_BASELINES = [b / 100.0 for b in range(35, 101, 5)]
#: FCR-D's full activation time [s] and the share of the request the ramp test asks for by then.
FCR_D_FULL_ACTIVATION, FCR_D_SHARE = 7.5, 0.86
COLUMNS = ("plain", "compensated", "control", "dispatch", "both")


def parser():
    p = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(p)
    p.add_argument("--modules", type=modules_count, default=100, help="modules of the hub [default: 100]")
    p.add_argument(
        "--baseline",
        type=baselines,
        default=DEFAULT_BASELINES,
        help="baselines in %% of rated power, comma-separated [default: 35,40,...,100]",
    )
    p.add_argument(
        "--products",
        type=cli.list_of(list(BY_NAME)),
        default=DEFAULT_PRODUCTS,
        help=f"comma-separated [default: {','.join(DEFAULT_PRODUCTS)}]",
    )
    p.add_argument("--dt", type=cli.positive(float), default=0.1, help="test step [s] [default: 0.1]")
    workers = p.add_argument(
        "--workers",
        dest="jobs",
        type=cli.positive(int),
        default=os.cpu_count() or 1,
        metavar="N",
        help="worker processes [default: one per core]",
    )
    cli.add_old_spelling(p, workers, "--jobs")
    cli.add_out_option(p, Path("out") / "operating_table", "the table and its figure")
    p.add_argument("--no-plots", action="store_true", help="no PNG figure")
    cli.add_version_option(p)
    return p


class Table:
    """The jobs of every cell, run through aem-prequalify's pool (`jobs`, a prequalify.Jobs);
    each hub × product once."""

    def __init__(self, args, jobs=None):
        from fmpy import read_model_description

        self.args, self.jobs = args, jobs
        start = {v.name: v.start for v in read_model_description(str(args.fmu)).modelVariables}
        names = ("gain", "voltageIntercept", "ohmicResistance", "minSetpoint", "maxSetpoint")
        self.curve = dispatch_search.ModuleCurve(*(float(start[n]) for n in names))
        self.ramp = float(start["rampUpLimit"])  # A/s
        self.standby = float(start["standbyPower"])  # W
        self.rated = args.modules * self.curve.power(self.curve.max_setpoint)
        self.taus = time_constants(args)

    def capacities(self, hubs, product):
        return self.jobs.capacities([(h, product.name) for h in hubs])

    def beats(self, hubs, product, floor):
        return self.jobs.beats([(h, product.name) for h in hubs], floor)

    def hub(self, dispatch, base, compensation=False, zero=0.0, count=None):
        a = self.args
        if count is not None:
            target = dispatch_search.target_setpoint(count, base * self.rated, self.curve)
            return Hub(a.modules, 4, BELOW_MINIMUM[4], base, False, (), zero, dispatch_target=target)
        return Hub(a.modules, dispatch, BELOW_MINIMUM[dispatch], base, compensation, (), zero)

    def equal_possible(self, base):
        return base * self.rated >= self.args.modules * self.curve.power(self.curve.min_setpoint) - 1e-9

    def cell(self, base, product):
        """{column: capacity [W]} and the details (zeros, counts) of one baseline and product."""
        policies = [1, 2] if self.equal_possible(base) else [2]
        plain = self.capacities([self.hub(d, base) for d in policies], product)
        compensated = self.capacities([self.hub(d, base, True) for d in policies], product)
        reference = policies[plain.index(max(plain))]
        tau_zero, t1, t2 = self.taus

        def zero_hub(z, count=None):
            if count is None and z == tau_zero:
                return self.hub(reference, base)
            if count is None and z == t2:
                return self.hub(reference, base, True)
            return self.hub(reference, base, zero=0.0 if z == tau_zero else z, count=count)

        control = optimise.search(
            lambda zs: self.capacities([zero_hub(z) for z in zs], product),
            min(t1, t2),
            max(t1, t2),
            known=(tau_zero, t2),
            beats=lambda zs, floor: self.beats([zero_hub(z) for z in zs], product, floor),
        )
        counts = dispatch_search.feasible_counts(self.args.modules, base * self.rated, self.curve)
        dispatch = dispatch_search.search(
            lambda ns: self.capacities([self.hub(4, base, count=n) for n in ns], product), counts
        )
        both = optimise.search(
            lambda zs: self.capacities([zero_hub(z, dispatch.count) for z in zs], product),
            min(t1, t2),
            max(t1, t2),
            known=(tau_zero,),
            beats=lambda zs, floor: self.beats([zero_hub(z, dispatch.count) for z in zs], product, floor),
        )
        # Ties go to the simpler configuration: the reference dispatch, then plain droop.
        joint = max(
            [(control.best.capacity, control.best.zero, None), (dispatch.capacity, tau_zero, dispatch.count)]
            + [(both.best.capacity, both.best.zero, dispatch.count)],
            key=lambda x: x[0],
        )
        by_dispatch = dispatch.capacity > max(plain)
        values = {
            "plain": max(plain),
            "compensated": max(compensated),
            "control": control.best.capacity,
            "dispatch": max(max(plain), dispatch.capacity),
            "both": joint[0],
        }
        details = {
            "reference dispatch": {1: "equal", 2: "sequential"}[reference],
            "best zero [s]": control.best.zero,
            "best count [1]": dispatch.count if by_dispatch else None,
            "both: zero [s]": joint[1],
            "both: count [1]": joint[2],
        }
        return values, details

    def window_bound(self, base, product):
        """The window's bound [W]: up to every module in standby, down to every one at maxSetpoint."""
        b = base * self.rated
        up, down = b - self.args.modules * self.standby, self.rated - b
        return {1: up, -1: down, 0: min(up, down)}[product.direction]

    def ramp_bound(self, base, product):
        """Downward FCR-D's bound from the rising-current limit [W]: over the feasible counts n,
        n·min(P(M) − B/n, P(I + r·7.5 s) − B/n)/0.86, I the current at B/n; None otherwise."""
        if product.name != "FCR-D down":
            return None
        b, c = base * self.rated, self.curve
        best = 0.0
        for n in dispatch_search.feasible_counts(self.args.modules, b, c):
            share = b / n
            i = c.gain * c.setpoint(share)
            v0, r = c.voltage_intercept, c.ohmic_resistance
            rise = (
                min(
                    c.power(c.max_setpoint),
                    (v0 + r * (i + self.ramp * FCR_D_FULL_ACTIVATION)) * (i + self.ramp * FCR_D_FULL_ACTIVATION),
                )
                - share
            )
            best = max(best, n * rise / FCR_D_SHARE)
        return min(best, self.window_bound(base, product))


def plot(path, rows, products, rated):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(products), figsize=(3.2 * len(products), 3.4), sharey=False, squeeze=False)
    for ax, name in zip(axes[0], products):
        mine = [r for r in rows if r["product"] == name]
        x = [r["baseline [% of rated]"] for r in mine]
        for column, style in zip(COLUMNS, ("-", "--", "-.", ":", "-")):
            ax.plot(x, [100 * r[f"{column} [W]"] / rated for r in mine], style, marker="o", ms=3, label=column)
        ax.plot(x, [100 * r["window bound [W]"] / rated for r in mine], color="0.6", lw=0.8, label="window bound")
        ramp = [r["ramp bound [W]"] for r in mine]
        if all(v is not None for v in ramp):
            ax.plot(x, [100 * v / rated for v in ramp], color="0.3", lw=0.8, ls="--", label="ramp bound")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("baseline [% of rated]")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("capacity [% of rated]")
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    p = parser()
    args = p.parse_args(argv)
    args.fmu = cli.resolve_fmu(p, args)
    args.settings = ()
    cli.writable_folder(args.out)
    table = Table(args)
    products = [BY_NAME[n] for n in args.products]
    low = [b for b in args.baseline if b * table.rated < table.curve.power(table.curve.min_setpoint)]
    if low:
        p.error(f"--baseline: {100 * low[0]:g} % is below one module at minSetpoint")
    start = time.perf_counter()
    with Jobs(args, desc="operating table") as jobs:
        table.jobs = jobs
        # Every cell's searches at once, each in a thread: their jobs keep both workers busy.
        cells = [(base, product) for base in args.baseline for product in products]
        found = jobs.each(lambda cell: table.cell(*cell), cells)
        assessments = len(jobs.futures)
    rows = []
    for (base, product), (values, details) in zip(cells, found):
        rows.append(
            {
                "product": product.name,
                "baseline [% of rated]": float(percent(base)),
                **{f"{k} [W]": v for k, v in values.items()},
                "window bound [W]": table.window_bound(base, product),
                "ramp bound [W]": table.ramp_bound(base, product),
                **details,
            }
        )
    elapsed = time.perf_counter() - start
    write(args.out, rows, table.rated, elapsed, args.modules)
    if not args.no_plots:
        plot(args.out / "table.png", rows, args.products, table.rated)
    for r in rows:
        cli.say(
            args,
            f"{r['product']:<11} {r['baseline [% of rated]']:>3g} %: "
            + ", ".join(f"{c} {100 * r[f'{c} [W]'] / table.rated:.2f} %" for c in COLUMNS),
        )
    cli.say(args, f"{len(rows)} cells, {assessments} assessments in {elapsed:.0f} s; the table in {args.out}")
    return 0


def write(out, rows, rated, elapsed, modules):
    report.write_rows(out / "table", rows)
    pct = lambda w: "–" if w is None else f"{100 * w / rated:.1f}"  # noqa: E731
    lines = [
        f"# Reserve capacity over the base power ({modules} modules, rated {rated / 1e3:.1f} kW; % of rated)",
        "",
        f"**{report.DISCLAIMER}**",
        "",
        "plain and compensated: the better of equal and sequential dispatch; control: the best zero with "
        "that dispatch; dispatch: the best running count with plain droop (target dispatch), or that "
        "dispatch where no count beats it; both: the best zero at the best count, or either lever alone "
        f"where that sells more. {elapsed:.0f} s on this machine.",
        "",
        "| product | baseline | plain | compensated | control | dispatch | both | window bound | ramp bound | "
        "count, zero of both |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        count = "–" if r["both: count [1]"] is None else r["both: count [1]"]
        lines.append(
            f"| {r['product']} | {r['baseline [% of rated]']:g} % | "
            + " | ".join(pct(r[f"{c} [W]"]) for c in COLUMNS)
            + f" | {pct(r['window bound [W]'])} | {pct(r['ramp bound [W]'])} | {count}, {r['both: zero [s]']:.3g} s |"
        )
    (out / "table.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    cli.run_command(main)


__all__ = ["Table", "main", "parser"]
