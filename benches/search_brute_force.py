"""The reserve control's search against brute force on the packaged FMU.

    .venv/bin/python benches/search_brute_force.py [--modules 4] [--baseline 50,70,80]
        [--products "FCR-N,FCR-D up,FCR-D down"] [--ratio 1.02] [--out target/bench/search]

For each product and baseline of an equal hub: every zero of a fine logarithmic grid over
[τp1, τp2] (neighbours `--ratio` apart) assessed in full (a bisection each, the tool's own
assessment), against the search of aem-prequalify --optimise (a scan every 5 % with a branch and
bound, then refined) and against the search as it was (seven grid zeros and one bracket). Prints
and writes (<out>/search.csv, .md) per case the brute force's best capacity and zero, each
search's, and their shortfall against the brute force [W]; exit status 1 if the search falls
short of the brute force by more than a bisection step anywhere. Slow (hours of CPU for the
defaults' grid): a validation, not a test; the tests hold its cheaper cases.
"""

import argparse
import csv
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, optimise
from aem_electrolyser.reserves.bisection import failing
from aem_electrolyser.reserves.products import BY_NAME, window_bound

TP1, TP2 = 1.995, 113.568


def sellable(args):
    """The sellable capacity [W] of `product` on an equal hub with its zero at `zero` [s]."""
    modules, baseline, product, zero = args
    runner = HubRunner(None, Hub(modules, 1, 0, baseline, False, (), zero))
    try:
        return assess.largest(runner, BY_NAME[product], 0.1)[0].sellable
    finally:
        runner.close()


def beats(args):
    """Whether `product` passes a bisection step above `floor` [W] with its zero at `zero`."""
    modules, baseline, product, zero, floor = args
    runner = HubRunner(None, Hub(modules, 1, 0, baseline, False, (), zero))
    try:
        spec = BY_NAME[product]
        capacity = floor + 0.005 * runner.rated_power
        if capacity > window_bound(spec, runner.baseline, runner.least_power, runner.rated_power):
            return False
        return not failing(assess.run_product(runner, spec, capacity, 0.1).results, spec.use_reduction)
    finally:
        runner.close()


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--modules", type=int, default=4)
    p.add_argument("--baseline", default="50,70,80")
    p.add_argument("--products", default="FCR-N,FCR-D up,FCR-D down")
    p.add_argument("--ratio", type=float, default=1.02)
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--out", type=Path, default=Path("target/bench/search"))
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    rows, short = [], False
    with ProcessPoolExecutor(a.workers) as pool:
        for product in a.products.split(","):
            for base in (float(b) / 100 for b in a.baseline.split(",")):
                started = time.time()
                fine = optimise.grid(TP1, TP2, resolution=a.ratio)
                brute = list(pool.map(sellable, [(a.modules, base, product, z) for z in fine]))
                k = max(range(len(fine)), key=lambda i: brute[i])
                spent = time.time() - started

                def capacities(zs):
                    return list(pool.map(sellable, [(a.modules, base, product, z) for z in zs]))

                def beaten(zs, floor):
                    return list(pool.map(beats, [(a.modules, base, product, z, floor) for z in zs]))

                started = time.time()
                new = optimise.search(capacities, TP1, TP2, known=(95.371, TP2), beats=beaten)
                new_time = time.time() - started
                old = optimise.search(
                    capacities, TP1, TP2, known=(95.371, TP2), resolution=(TP2 / TP1) ** (1 / 6), count=1
                )
                step = 0.005 * HubRunner(None, Hub(a.modules, 1, 0, base)).rated_power
                row = {
                    "product": product,
                    "baseline [%]": round(100 * base),
                    "brute force zeros [1]": len(fine),
                    "brute force best [W]": round(brute[k]),
                    "brute force zero [s]": round(fine[k], 3),
                    "search best [W]": round(new.best.capacity),
                    "search zero [s]": round(new.best.zero, 3),
                    "search shortfall [W]": round(max(0.0, brute[k] - new.best.capacity)),
                    "search zeros tried [1]": len(new.tried),
                    "search full bisections [1]": sum(not c.bound for c in new.tried),
                    "old search best [W]": round(old.best.capacity),
                    "old search shortfall [W]": round(max(0.0, brute[k] - old.best.capacity)),
                    "brute force time [s]": round(spent, 1),
                    "search time [s]": round(new_time, 1),
                }
                short |= brute[k] - new.best.capacity > step + 1e-6
                rows.append(row)
                print(", ".join(f"{key} {value}" for key, value in row.items()), flush=True)
    with open(a.out / "search.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    (a.out / "search.md").write_text("\n".join(lines) + "\n")
    return 1 if short else 0


if __name__ == "__main__":
    raise SystemExit(main())
