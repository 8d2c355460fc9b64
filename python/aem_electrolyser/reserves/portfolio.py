#!/usr/bin/env python3
"""The configuration that earns the most from a set of reserve products sold together, at the
energy cost it has: per base power, one running count (target dispatch), how many of the other
modules wait in warm standby (the rest idle, cold) and one reserve control (the zero τn of the
setpoint pre-filter) for every product, chosen to maximise the hourly value

    V [€/h] = Σ_p price_p [€/(MW·h)] · C_p [MW] + hydrogen value [€/kg] · H [kg/h]

C_p being the capacity of product p, prequalified as aem-prequalify does (its test programme on
the FMU, the largest passing capacity by bisection), and H the hub's hydrogen production at the
base power (the FMU's hubH2MassFlow in steady state). Every configuration draws the same power,
the base power (hubPower, reported), so the electricity bought is the same; what a configuration
costs is the hydrogen it does not make: fewer modules at a higher current work at a higher cell
voltage, and the standby power of the modules kept warm comes out of the same base power (a
warm module starts in warmStartTime, an idle one in coldStartTime).

    python -m aem_electrolyser.reserves.portfolio [--modules 100] [--baseline 50,80]
        [--prices "FCR-D up=1,FCR-D down=1"] [--hydrogen-value 0]
        [--out out/portfolio]

The search (deterministic, no random draw), one round of coordinate search: the running count
by aem-prequalify --optimise-dispatch's search, on V with plain droop, each count with no module
warm and with the most the base power allows (their standby power must leave every running
module at least its minimum; at most the modules not running), the better of the two; the zero
in [τp1, τp2] by --optimise's search, on V at that count, scanned every 25 % (no bound prunes
V, so every zero costs every product's bisection) with the best refined; then the modules held warm, 0, ¼, ½,
¾ or all of the most. Ties go to the fewest running modules, plain droop and the
fewest warm modules. Against it, per baseline, plain droop with equal dispatch (where every
module can run) and with sequential dispatch (the fewest modules), no module warm.

Where FCR-N and an FCR-D product are both sold, a configuration must also pass the FCR-D fast
ramp test's combination ramps 7-8 with both capacities set (NTR §3.1.2 Req. 1b: the response to
49.7 and 49.89 Hz, mirrored downward, within −5…+20 % of C_FCR-N plus FCR-D's share); where it
fails, it sells the products worth more (FCR-N with the FCR-D products that passed beside it,
or the FCR-D products without FCR-N).

Writes <out>/portfolio.md, .csv and .json, then prints one line per baseline and configuration.
The capacities in % of rated power of a hub of N modules hold for any hub with the same running
counts per module; the default 100 modules keep it to minutes.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from aem_electrolyser import cli
from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, dispatch_search, evaluate, optimise, report, signals
from aem_electrolyser.reserves.requirement import FAIL
from aem_electrolyser.reserves.prequalify import (
    BELOW_MINIMUM,
    BY_NAME,
    baselines,
    module_curve,
    modules_count,
    percent,
    Jobs,
    time_constants,
)

DEFAULT_PRICES = {"FCR-D up": 1.0, "FCR-D down": 1.0}
#: The FCR-D products whose fast ramp test ends with the combination ramps 7-8 when FCR-N is
#: sold too (NTR §3.1.2 Req. 1b).
WITH_FCR_N = ("FCR-D up", "FCR-D down")

#: The portfolio's scan of the reserve control's zero: neighbours at most 25 % apart (20 zeros
#: over the paper's [τp1, τp2]), the best refined. Coarser than one product's search
#: (optimise.RESOLUTION, 5 %): a configuration's value sums every product's capacity and has no
#: bound that prunes, so each zero costs every product's bisection; a band of one product
#: narrower than 25 % may fall between its zeros (aem-prequalify --optimise finds it).
RESOLUTION = 1.25


def prices(text):
    """{product name: price [€/(MW·h)]} from "name=price,name=price"; each product once, each
    price finite and ≥ 0."""
    out = {}
    for item in (x.strip() for x in str(text).split(",")):
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep:
            raise argparse.ArgumentTypeError(f"{item!r} is not product=price (e.g. 'FCR-D up=10')")
        if name not in BY_NAME:
            raise argparse.ArgumentTypeError(
                f"{name!r} is not a product; give one of {', '.join(BY_NAME)}{cli.did_you_mean(name, BY_NAME)}"
            )
        if name in out:
            raise argparse.ArgumentTypeError(f"{name!r} is priced twice")
        try:
            out[name] = cli.non_negative(float)(value.strip())
        except argparse.ArgumentTypeError as e:
            raise argparse.ArgumentTypeError(f"{name}'s price {e}") from None
    return out


def parser():
    p = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(p)
    p.add_argument("--modules", type=modules_count, default=100, help="modules of the hub [default: 100]")
    p.add_argument(
        "--baseline", type=baselines, default=[0.5, 0.8], help="baselines in %% of rated power [default: 50,80]"
    )
    p.add_argument(
        "--prices",
        type=prices,
        default=DEFAULT_PRICES,
        help="the products sold together and their capacity prices [€/(MW·h)], as 'name=price,...' "
        "[default: 'FCR-D up=1,FCR-D down=1': the megawatts sold]",
    )
    p.add_argument(
        "--hydrogen-value", type=cli.non_negative(float), default=0.0, help="€/kg of hydrogen made [default: 0]"
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
    cli.add_out_option(p, Path("out") / "portfolio", "the portfolio's tables")
    cli.add_version_option(p)
    return p


@dataclass(frozen=True)
class Configuration:
    """One way to run the hub at a baseline and what it earns: running modules, modules held in
    warm standby, the zero [s], capacities {product: W}, the hub's power [W] and hydrogen
    production [kg/h] in steady state, and the hourly value [€/h]."""

    name: str
    hub: Hub
    count: int
    standby: int
    zero: float
    capacities: dict
    power: float
    hydrogen: float
    value: float
    together: str = ""


class Portfolio:
    """Capacities (each hub × product assessed once, through aem-prequalify's pool), steady
    states and values of the configurations tried."""

    def __init__(self, args, jobs=None):
        self.args, self.jobs, self.steady_states, self.combinations = args, jobs, {}, {}
        self.curve = module_curve(args)
        from fmpy import read_model_description

        start = {v.name: v.start for v in read_model_description(str(args.fmu)).modelVariables}
        self.standby_power = float(start["standbyPower"])  # W
        self.rated = args.modules * self.curve.power(self.curve.max_setpoint)
        self.taus = time_constants(args)
        self.products = list(args.prices)

    def hub(self, base, count, zero, standby=0):
        """Target dispatch running `count` modules at baseline `base`, `standby` of the others
        warm; plain droop at zero = τz."""
        target = dispatch_search.target_setpoint(count, base * self.rated, self.curve)
        filter_zero = 0.0 if zero == self.taus[0] else zero
        return Hub(
            self.args.modules,
            4,
            BELOW_MINIMUM[4],
            base,
            False,
            (),
            filter_zero,
            dispatch_target=target,
            initial_standby=standby,
        )

    def reference_hub(self, base, policy):
        return Hub(self.args.modules, policy, BELOW_MINIMUM[policy], base)

    def configurations(self, named):
        """[Configuration] of (name, hub, count, zero) tuples, their jobs run together."""
        done = self.jobs.run([(hub, p) for _, hub, _, _ in named for p in self.products])
        out = []
        for name, hub, count, zero in named:
            sold = {p: done[(hub, p)][0].sellable for p in self.products}
            capacities, together = self.sold_together(hub, sold)
            power, hydrogen = self.steady(hub)
            value = self.value(capacities, hydrogen)
            out.append(
                Configuration(name, hub, count, hub.initial_standby, zero, capacities, power, hydrogen, value, together)
            )
        return out

    def sold_together(self, hub, capacities):
        """(capacities, what the combination tests found): where FCR-N and an FCR-D product are both
        sold, the FCR-D fast ramp test with its combination ramps 7-8 runs on the FMU with both
        capacities set, and the response to each ramp must lie within −5…+20 % of C_FCR-N plus
        FCR-D's share (NTR §3.1.2 Req. 1b). Where one fails, the configuration sells the products
        worth more: FCR-N with the FCR-D products that passed beside it, or every FCR-D product
        without FCR-N (upward and downward never activate together); the others' capacity 0."""
        capacities = dict(capacities)
        pairs = [p for p in WITH_FCR_N if capacities.get("FCR-N", 0.0) > 0.0 and capacities.get(p, 0.0) > 0.0]
        notes, failed = [], []
        for product in pairs:
            results = self.combination(hub, capacities["FCR-N"], product, capacities[product])
            found = ", ".join(f"{r.measured:+.1f} %".replace("-", "−") for r in results)
            verdict = "fails" if any(r.status == FAIL for r in results) else "passes"
            if verdict == "fails":
                failed.append(product)
            notes.append(f"FCR-N + {product}: Req. 1b {verdict} ({found}; −5…+20 %)")
        if failed:
            prices = self.args.prices

            def worth(names):
                return sum(prices[name] * capacities[name] for name in names)

            with_fcr_n = ["FCR-N"] + [p for p in pairs if p not in failed]
            dropped = failed if worth(with_fcr_n) > worth(pairs) else ["FCR-N"]
            for name in dropped:
                capacities[name] = 0.0
            notes.append(f"{' and '.join(dropped)} not sold")
        return capacities, "; ".join(notes)

    def combination(self, hub, c_n, product, c_d):
        """Req. 1b's results for FCR-N at c_n [W] and `product` (an FCR-D one) at c_d [W] on `hub`
        (its fast ramp test with ramps 7-8, both capacities set), run once per hub and capacities."""
        key = (hub, c_n, product, c_d)
        if key not in self.combinations:
            fcr_n, fcr_d = BY_NAME["FCR-N"], BY_NAME[product]
            signal = signals.fcr_d_ramp(fcr_d.direction, self.args.dt, combination=True)
            parameters = {
                **fcr_n.parameters,
                **fcr_d.parameters,
                fcr_n.capacity_parameter: c_n,
                fcr_d.capacity_parameter: c_d,
            }
            runner = HubRunner(self.args.fmu, hub)
            try:
                trace = assess.trace(runner, signal, c_d, parameters)
            finally:
                runner.close()
            results = evaluate.fcr_d_ramp(trace, c_d, signal, fcr_n_capacity=c_n)
            self.combinations[key] = [r for r in results if "Req. 1b" in r.name]
        return self.combinations[key]

    def steady(self, hub):
        """(hubPower [W], hubH2MassFlow [kg/h]) of the hub at its baseline, from the FMU."""
        if hub not in self.steady_states:
            runner = HubRunner(self.args.fmu, hub)
            try:
                state = runner.steady(["hubPower", "hubH2MassFlow"])
            finally:
                runner.close()
            self.steady_states[hub] = (state["hubPower"], state["hubH2MassFlow"])
        return self.steady_states[hub]

    def value(self, capacities, hydrogen):
        """V [€/h] = Σ price·C [MW] + hydrogen value·H [kg/h]."""
        a = self.args
        return sum(a.prices[p] * c / 1e6 for p, c in capacities.items()) + a.hydrogen_value * hydrogen

    def most_warm(self, base, count):
        """The most modules that can wait warm beside `count` running ones at baseline `base`: their
        standby power comes out of the base power, which must leave each running module at least
        its minimum, (B − n·P(m))/standbyPower, and no more than the modules not running."""
        room = base * self.rated - count * self.curve.power(self.curve.min_setpoint)
        idle = self.args.modules - count
        if self.standby_power <= 0.0:
            return idle
        return max(0, min(idle, math.floor(room / self.standby_power + 1e-9)))

    def best(self, base):
        """The best configuration at baseline `base` and the references, best first."""
        tau_zero, t1, t2 = self.taus
        counts = dispatch_search.feasible_counts(self.args.modules, base * self.rated, self.curve)

        def values(named):
            return [c.value for c in self.configurations(named)]

        warm_at = {}  # count → the modules held warm with it in the count search (none or the most)

        def by_count(ns):
            ends = [(n, k) for n in ns for k in dict.fromkeys((0, self.most_warm(base, n)))]
            found = self.configurations([("", self.hub(base, n, tau_zero, k), n, tau_zero) for n, k in ends])
            for c in found:  # the first of equals: no module warm
                if c.count not in warm_at or c.value > warm_at[c.count].value:
                    warm_at[c.count] = c
            return [warm_at[n].value for n in ns]

        dispatch = dispatch_search.search(by_count, counts)
        n, k = dispatch.count, warm_at[dispatch.count].standby
        control = optimise.search(
            lambda zs: values([("", self.hub(base, n, z, k), n, z) for z in zs]),
            min(t1, t2),
            max(t1, t2),
            known=(tau_zero,),
            resolution=RESOLUTION,
            count=1,
        )
        zero = control.best.zero if control.best.capacity > dispatch.capacity else tau_zero
        most = self.most_warm(base, n)
        warm = [("", self.hub(base, n, zero, k), n, zero) for k in sorted({round(most * q / 4) for q in range(5)})]
        best = max(self.configurations(warm), key=lambda c: c.value)  # the first of equals: the fewest warm
        named = [("best", best.hub, n, zero)]
        if base * self.rated >= self.args.modules * self.curve.power(self.curve.min_setpoint) - 1e-9:
            named.append(("equal, plain droop", self.reference_hub(base, 1), self.args.modules, tau_zero))
        named.append(("sequential, plain droop", self.reference_hub(base, 2), counts[0], tau_zero))
        return self.configurations(named)


def rows_of(portfolio, base, configurations):
    rated, curve = portfolio.rated, portfolio.curve
    rows = []
    for c in configurations:
        setpoint = c.hub.dispatch_target if c.hub.dispatch == 4 else curve.setpoint(base * rated / c.count)
        rows.append(
            {
                "baseline [% of rated]": float(percent(base)),
                "configuration": c.name,
                "running modules [1]": c.count,
                "warm standby [1]": c.standby,
                "setpoint [%]": setpoint,
                "reserve filter zero [s]": c.zero,
                **{f"{p} [W]": w for p, w in c.capacities.items()},
                "hub power [W]": c.power,
                "hydrogen [kg/h]": c.hydrogen,
                "value [EUR/h]": c.value,
                "sold together (Req. 1b)": c.together,
            }
        )
    return rows


def write(out, rows, portfolio, elapsed):
    args, rated = portfolio.args, portfolio.rated
    report.write_rows(out / "portfolio", rows, leave_out=("sold together (Req. 1b)",), digits=9)
    sold = ", ".join(f"{p} at {v:g} €/(MW·h)" for p, v in args.prices.items())
    lines = [
        f"# Reserve products sold together ({args.modules} modules, rated {rated / 1e3:.1f} kW)",
        "",
        f"**{report.DISCLAIMER}**",
        "",
        f"Sold together: {sold}; hydrogen at {args.hydrogen_value:g} €/kg. Value V = Σ price · capacity "
        "+ hydrogen value · production; every configuration draws the base power. Capacities in % of "
        f"rated power. {elapsed:.0f} s on this machine.",
        "",
        "| baseline | configuration | running modules | warm standby | setpoint | zero | "
        + " | ".join(portfolio.products)
        + " | hub power | hydrogen | value |",
        "|---" * (9 + len(portfolio.products)) + "|",
    ]
    for r in rows:
        lines.append(
            f"| {r['baseline [% of rated]']:g} % | {r['configuration']} | {r['running modules [1]']} | "
            f"{r['warm standby [1]']} | "
            f"{r['setpoint [%]']:.4g} % | {r['reserve filter zero [s]']:.4g} s | "
            + " | ".join(f"{100 * r[f'{p} [W]'] / rated:.2f} %" for p in portfolio.products)
            + f" | {r['hub power [W]'] / 1e3:.2f} kW | {r['hydrogen [kg/h]']:.4g} kg/h | {r['value [EUR/h]']:.4g} €/h |"
        )
    together = [r for r in rows if r["sold together (Req. 1b)"]]
    if together:
        lines += ["", "FCR-N and FCR-D sold together, the FCR-D fast ramp test's combination ramps 7-8 (Req. 1b):", ""]
        lines += [
            f"- {r['baseline [% of rated]']:g} %, {r['configuration']}: {r['sold together (Req. 1b)']}"
            for r in together
        ]
    (out / "portfolio.md").write_text("\n".join(lines) + "\n")


def main(argv=None):
    p = parser()
    args = p.parse_args(argv)
    args.fmu = cli.resolve_fmu(p, args)
    args.settings = ()
    cli.writable_folder(args.out)
    portfolio = Portfolio(args)
    low = [b for b in args.baseline if b * portfolio.rated < portfolio.curve.power(portfolio.curve.min_setpoint)]
    if low:
        p.error(f"--baseline: {100 * low[0]:g} % is below one module at minSetpoint")
    start = time.perf_counter()
    with Jobs(args, desc="portfolio") as jobs:
        portfolio.jobs = jobs
        # Every baseline's search at once, each in a thread: their jobs keep every worker busy.
        found = jobs.each(portfolio.best, list(args.baseline))
        assessments = len(jobs.futures)
    rows = [
        row for base, configurations in zip(args.baseline, found) for row in rows_of(portfolio, base, configurations)
    ]
    elapsed = time.perf_counter() - start
    write(args.out, rows, portfolio, elapsed)
    for r in rows:
        cli.say(
            args,
            f"{r['baseline [% of rated]']:>3g} % {r['configuration']:<24} {r['running modules [1]']:>6} modules "
            f"({r['warm standby [1]']} warm), "
            f"zero {r['reserve filter zero [s]']:.4g} s: "
            + ", ".join(f"{p} {100 * r[f'{p} [W]'] / portfolio.rated:.2f} %" for p in portfolio.products)
            + f", {r['hydrogen [kg/h]']:.4g} kg/h, {r['value [EUR/h]']:.4g} €/h",
        )
    cli.say(args, f"{assessments} assessments in {elapsed:.0f} s; the tables in {args.out}")
    return 0


if __name__ == "__main__":
    cli.run_command(main)


__all__ = ["Configuration", "Portfolio", "main", "parser", "prices"]
