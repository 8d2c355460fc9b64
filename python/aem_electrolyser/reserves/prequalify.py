#!/usr/bin/env python3
"""Prequalification of an electrolyser hub for frequency reserves, on the packaged FMU.

    aem-prequalify [--modules 25000] [--dispatch equal] [--baseline 80]
        [--compensation both] [--products all] [--out out/prequalification] [--no-plots]

For each hub (dispatch × baseline, each plain and/or with reserveCompensation) and each product
(Nordic FCR-D up/down dynamic and static, FCR-N, FFR at 49.7/49.6/49.5 Hz, Continental FCR,
aFRR and mFRR up/down) it runs the product's test programme on the FMU (fmpy, 0.1 s steps, a
fresh instance per test), evaluates every requirement against its limit and searches by
bisection the largest capacity that passes, up to what the operating window allows at the
baseline (reduction factors applied where the rules allow them). Writes, per hub,
<out>/<hub>.md, .csv and .json (each requirement: measured against its limit, pass/fail, the
largest capacity in W and % of rated power, the limiting requirement) and, unless --no-plots,
PNG plots of every test at that capacity; then <out>/summary.md and .csv (products × hubs) and
prints the summary. Several values of --dispatch, --baseline are comma-separated. Jobs run in
parallel processes (--jobs, default one per core).

This is a model-based assessment of the test programme (Nordic FCR technical requirements
v1.1 of 28 March 2025 and test programme, Fingrid FFR, SO GL Annex V), not a prequalification
approval; rules that could not be confirmed are reported as unsure (informative).
"""
import argparse
import csv
import os
import re
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from aem_electrolyser.cli import add_fmu_option, resolve_fmu, quiet_on_closed_stdout, writable_folder
from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, report
from aem_electrolyser.reserves.products import BY_NAME, PRODUCTS

DISPATCH = {"equal": (1, 0), "sequential": (2, 1)}


def hub_name(hub: Hub) -> str:
    policy = {1: "equal", 2: "sequential"}[hub.dispatch]
    return f"{policy}_{round(100 * hub.baseline)}pct_{'compensated' if hub.compensation else 'plain'}"


def job(fmu, hub, product_name, dt):
    """One product on one hub (in a worker process): (CapacityResult, Run at it, rated power)."""
    runner = HubRunner(fmu, hub)
    try:
        result, at = assess.largest(runner, BY_NAME[product_name], dt)
        return result, at, runner.rated_power
    finally:
        runner.close()


def sellable(result) -> float:
    """The capacity to sell [W]: after the reduction factors where they apply."""
    return result.reduced_capacity if result.reduced_capacity is not None else result.capacity


def limiting_text(result) -> str:
    if result.upper_bound_passes:
        return "operating window"
    return "; ".join(r.name for r in result.limiting) or "–"


def plot_run(folder: Path, stem: str, product, at):
    for k, (signal, trace) in enumerate(at.tests):
        report.plot_time_test(folder / f"{stem}_{slug(product.name)}_{k + 1}.png", signal, trace, at.capacity)
    if at.points:
        report.plot_nyquist(folder / f"{stem}_{slug(product.name)}_nyquist.png", at.points, product.sine)


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")


def write_summary(out: Path, hubs, products, results, rated):
    """summary.md and summary.csv: per product and hub, the largest capacity and what limits it."""
    rows = []
    for product in products:
        for hub in hubs:
            r = results[(hub, product.name)]
            rows.append((product.name, hub, sellable(r), 100 * sellable(r) / rated, limiting_text(r)))
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["product", "dispatch", "baseline [% of rated]", "compensation", "largest capacity [W]",
                    "largest capacity [% of rated]", "limiting requirement"])
        for name, hub, c, pct, lim in rows:
            w.writerow([name, {1: "equal", 2: "sequential"}[hub.dispatch], round(100 * hub.baseline),
                        "on" if hub.compensation else "off", f"{c:.10g}", f"{pct:.4g}", lim])
    lines = [f"# Largest capacity per product (rated power {rated / 1e6:.2f} MW)", "", f"**{report.DISCLAIMER}**", "",
             "| product | " + " | ".join(hub_label(h) for h in hubs) + " |", "|---|" + "---|" * len(hubs)]
    for product in products:
        cells = []
        for hub in hubs:
            r = results[(hub, product.name)]
            cells.append(f"{sellable(r) / 1e6:.2f} MW ({100 * sellable(r) / rated:.1f} %): {limiting_text(r)}")
        lines.append(f"| {product.name} | " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    return rows


def hub_label(hub: Hub) -> str:
    policy = {1: "equal", 2: "sequential"}[hub.dispatch]
    return f"{policy} {round(100 * hub.baseline)} %{' compensated' if hub.compensation else ''}"


def main(argv=None):
    parser = argparse.ArgumentParser(prog="aem-prequalify", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_fmu_option(parser)
    parser.add_argument("--modules", type=int, default=25_000)
    parser.add_argument("--dispatch", default="equal", help="equal, sequential (comma-separated)")
    parser.add_argument("--baseline", default="80", help="baseline consumption, %% of rated power (comma-separated)")
    parser.add_argument("--compensation", choices=("off", "on", "both"), default="both")
    parser.add_argument("--products", default="all", help="comma-separated names, e.g. 'FCR-D up,FCR-N' (default all)")
    parser.add_argument("--dt", type=float, default=0.1, help="test signal sampling and FMU step [s]")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", type=Path, default=Path("out") / "prequalification")
    parser.add_argument("--no-plots", action="store_true")
    args = parser.parse_args(argv)
    args.fmu = resolve_fmu(parser, args)
    try:
        policies = [DISPATCH[d.strip()] for d in args.dispatch.split(",")]
        baselines = [float(b) / 100.0 for b in args.baseline.split(",")]
    except (KeyError, ValueError) as e:
        parser.error(f"--dispatch or --baseline: {e}")
    if any(not 0.0 < b <= 1.0 for b in baselines):
        parser.error("--baseline: each must be within (0, 100] %")
    names = [p.name for p in PRODUCTS] if args.products == "all" else [n.strip() for n in args.products.split(",")]
    unknown = [n for n in names if n not in BY_NAME]
    if unknown:
        parser.error(f"--products: unknown {unknown}; choose from {', '.join(BY_NAME)}")
    products = [BY_NAME[n] for n in names]
    modes = {"off": [False], "on": [True], "both": [False, True]}[args.compensation]
    hubs = [Hub(args.modules, d, b, base, c) for d, b in policies for base in baselines for c in modes]
    writable_folder(args.out)
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {(hub, p.name): pool.submit(job, args.fmu, hub, p.name, args.dt) for hub in hubs for p in products}
        done = {key: f.result() for key, f in futures.items()}
    elapsed = time.perf_counter() - start
    results = {key: r for key, (r, _, _) in done.items()}
    rated = next(iter(done.values()))[2]
    for hub in hubs:
        stem = hub_name(hub)
        sections = [assess.section(p, *done[(hub, p.name)][:2]) for p in products]
        title = f"Reserve prequalification (model-based): {hub.describe()}"
        report.write_report(args.out, stem, sections, title, rated)
        if not args.no_plots:
            for p in products:
                at = done[(hub, p.name)][1]
                if at is not None:
                    plot_run(args.out, stem, p, at)
    rows = write_summary(args.out, hubs, products, results, rated)
    print(f"{'product':<20} {'hub':<28} {'largest capacity':>22}  limiting requirement")
    for name, hub, c, pct, lim in rows:
        print(f"{name:<20} {hub_label(hub):<28} {c / 1e6:9.3f} MW ({pct:5.1f} %)  {lim}")
    print(f"{len(hubs)} hub(s) x {len(products)} product(s) assessed in {elapsed:.1f} s; reports in {args.out}")


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
