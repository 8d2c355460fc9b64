#!/usr/bin/env python3
"""Benchmark of aem-study (printed figures, not a timed test), all measured in this run:

1. One year at 1 s of the 60 MW hub (25 000 modules, sequential dispatch) following a
   generated year of the 64 MW wind farm, as one scenario of aem-study (serial): seconds per
   scenario, of which aem-run (the native master driving the packaged FMU) and the wind year's
   generation; against the FMU's own cost through its C interface (`cargo bench --bench hub`,
   sequential, C ABI, s/day x 365; scripts/bench.sh runs it first and this script reads
   target/benches/hub.txt), and aem-run on that benchmark's own day for a like-for-like ratio.
2. Scenarios per hour, serial against a LocalCluster of one worker process per core, on a
   study of --scenarios seeds x --days days of the same hub (the same scenarios both times:
   the store is emptied between the runs), and the speed-up.
3. The NREL `electrolyzer` peer (benches/nrel_peer.py in .venv-nrel, made by benches/nrel_bench.sh)
   on the first --nrel-hours of the same wind year, extrapolated to the year: a lower bound,
   as its per-step cost grows with simulated time.

    .venv/bin/python benches/study_bench.py [--days-per-scenario 60] [--scenarios 4] [--nrel-hours 1]
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parent.parent
from aem_electrolyser import locate
from aem_electrolyser.study import engine
from aem_electrolyser.study.definition import Study
from aem_electrolyser.wind.year import farm_power_year
from wind_reference import wind_reference  # benches/, the script's own folder

OUT = ROOT / "target" / "bench" / "study"
HUB = """[parameters]
nModules = 25000
dispatch = "sequential"
belowMinimum = "standby"
[series.wind]
generator = "wind"
"""


def study_file(name, days, seeds):
    path = OUT / f"{name}.toml"
    path.write_text(f'[study]\ntitle = "{name}"\nhorizon = "{days} d"\n{HUB}[axes]\nseed = {list(seeds)}\n')
    return Study(path)


def timed_run(study, out, **kwargs):
    """Wall time [s] of running every scenario of `study` from an empty store, and the records."""
    shutil.rmtree(out, ignore_errors=True)
    started = time.perf_counter()
    with open(os.devnull, "w") as quiet:
        records = engine.run(study, out, stream=quiet, **kwargs)
    seconds = time.perf_counter() - started
    failed = [r["message"] for r in records.values() if r["status"] != "done"]
    if failed:
        sys.exit(f"study_bench: scenarios failed: {failed}")
    return seconds, records


def c_interface_day():
    """s/day of the sequential hub through the FMU's C interface, from cargo bench --bench hub."""
    path = ROOT / "target" / "bench" / "hub.txt"
    if not path.is_file():
        return None
    match = re.search(r"^C ABI sequential\s+([0-9.]+) s/day", path.read_text(), re.M)
    return float(match.group(1)) if match else None


def aem_run_seconds(reference):
    """Wall time [s] of aem-run over `reference` [W] with the hub of this benchmark."""
    path = OUT / "reference.f64"
    reference.astype("<f8").tofile(path)
    args = [
        str(locate.binary("aem-run")),
        "--fmu",
        str(locate.fmu_path()),
        "--reference",
        str(path),
        "--step",
        "1",
        "--param",
        "nModules=25000",
        "--param",
        "dispatch=2",
        "--param",
        "belowMinimum=1",
    ]
    started = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - started
    return seconds, json.loads(done.stdout)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--days-per-scenario", type=int, default=60)
    parser.add_argument("--scenarios", type=int, default=4)
    parser.add_argument("--nrel-hours", type=float, default=1.0)
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    cores = os.cpu_count()

    year = study_file("year", 365, [1])
    wall, records = timed_run(year, OUT / "year-out", serial=True)
    (record,) = records.values()
    started = time.perf_counter()
    wind = farm_power_year(365 * 86400.0, seed=1, threads=1)  # as a worker generates it
    generation = time.perf_counter() - started
    kpis = record["kpis"]
    print(
        f"one year at 1 s, {kpis['modules [1]']} modules ({kpis['hub rated power [MW]']:.1f} MW), sequential, "
        f"generated 64 MW wind (seed 1): {wall:.1f} s per scenario (aem-run {record['run time [s]']:.1f} s, "
        f"wind year {generation:.1f} s); {kpis['hydrogen [kg]'] / 1e3:.0f} t H2, "
        f"{kpis['starts per module [1]']:.1f} starts per module"
    )
    per_day = c_interface_day()
    if per_day is None:
        print(
            "  (no target/benches/hub.txt from cargo bench --bench hub: run scripts/bench.sh for the C-interface ratio)"
        )
    else:
        bench_day = wind_reference(86400, 60e6, seed=42)
        seconds, _ = aem_run_seconds(bench_day)
        print(
            f"  the FMU through its C interface (cargo bench --bench hub, sequential): {per_day:.3f} s/day, "
            f"{per_day * 365:.0f} s/year; aem-study/C interface: {wall / (per_day * 365):.2f} "
            f"(target <= 1.5); aem-run on that benchmark's day: {seconds:.3f} s, ratio {seconds / per_day:.2f}"
        )

    from distributed import LocalCluster

    started = time.perf_counter()
    with LocalCluster(n_workers=cores, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None):
        pass
    cluster_start = time.perf_counter() - started
    throughput = study_file("throughput", args.days_per_scenario, range(1, args.scenarios + 1))
    serial, _ = timed_run(throughput, OUT / "throughput-serial", serial=True)
    cluster, records = timed_run(throughput, OUT / "throughput-cluster", workers=cores)
    workers = len({r["worker"] for r in records.values()})
    n = args.scenarios
    print(
        f"{n} scenarios of {args.days_per_scenario} days: serial {serial:.1f} s ({n / serial * 3600:.0f} "
        f"scenarios/h), LocalCluster of {cores} worker processes {cluster:.1f} s incl. its start and stop "
        f"({cluster_start:.1f} s alone) "
        f"({n / cluster * 3600:.0f} scenarios/h, {workers} workers ran scenarios): speed-up {serial / cluster:.2f} "
        f"on {cores} cores"
    )
    fixed = cluster - serial / workers
    print(
        f"  the cluster run's fixed cost (start, imports on the workers, sending FMU and aem-run): about "
        f"{fixed:.0f} s; year-long scenarios: {3600 / wall:.0f}/h serial, about {3600 / wall * workers:.0f}/h on "
        f"the LocalCluster once that cost is spread over a study"
    )

    peer = ROOT / ".venv-nrel" / "bin" / "python"
    if not peer.is_file():
        print("  (no .venv-nrel: bash benches/nrel_bench.sh makes it; the NREL peer is skipped)")
        return
    path = OUT / "wind_year.f64"
    wind[: int(args.nrel_hours * 3600)].astype("<f8").tofile(path)
    done = subprocess.run(
        [str(peer), str(ROOT / "bench" / "nrel_peer.py"), "--hours", str(args.nrel_hours), "--reference", str(path)],
        capture_output=True,
        text=True,
        check=True,
    )
    match = re.search(r"EXTRAPOLATED, a lower bound, from [0-9.]+ h: ([0-9.]+) s", done.stdout)
    measured = (
        float(match.group(1)) if match else float(re.search(r"^nrel: ([0-9.]+) s/day", done.stdout, re.M).group(1))
    )
    peer_year = measured / args.nrel_hours * 8760
    print(
        f"NREL electrolyzer (60 x 1 MW PEM stacks) on the first {args.nrel_hours:g} h of the same wind year: "
        f"{measured:.1f} s, extrapolated {peer_year:.0f} s/year (a lower bound); ratio to aem-study's scenario "
        f"{peer_year / wall:.0f}x"
    )


if __name__ == "__main__":
    main()
