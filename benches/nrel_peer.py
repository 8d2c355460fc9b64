#!/usr/bin/env python3
"""Peer benchmark: NREL's `electrolyzer` package (PyPI 0.2.1, "a controls-oriented engineering
electrolyzer model") simulating one day at 1 s of a 60-stack, 60 MW PEM plant that follows the
same wind-like power reference as benches/hub_fmpy.py (issue 4). Runs in .venv-nrel (made by
benches/nrel_bench.sh), not in the project's .venv.

    .venv-nrel/bin/python benches/nrel_peer.py [--hours H] [--control TYPE]

What the peer models, per stack and step: a PEM cell polarisation (Nernst open-circuit voltage,
Butler-Volmer activation, Nafion ohmic overpotential) inverted by a fitted quadratic
current(power, temperature), Faraday efficiency, a first-order (tau = 5 s) filter on the hydrogen
flow, a 600 s start-up wait, and voltage degradation (steady, on/off cycles, and hourly
rainflow-counted fatigue); a Supervisor decides which stacks run and shares the plant power.

Settings (and why):
- 60 PEM stacks of 1 MW, sized by the package's own tool (`calc_rated_system`: system_rating_MW
  60, stack_rating_kW 1000, from the PEM example of its README: 100 cells, max_current 2000 A,
  60 degC; the tool adjusts n_cells, cell area and max_current to reach 1 MW at 2 A/cm2). Every
  other cell and degradation parameter is the schema default (PEM defaults).
- dt = 1 s (the schema default), so the 5 s hydrogen dynamics and the 600 s start-up delay are on.
- controller: the schema default, DecisionControl with the `baseline` policy ("treat all stacks
  as a single large capacity electrolyzer": all stacks on and power split evenly when the plant
  can run them all above turndown), the nearest to our `equal` hub dispatch; --control picks
  another of the package's controllers (e.g. BaselineDeg, the example's).
- initialize = True at the reference's first value, as our hub starts in steady state.
- reference: benches/wind_reference.py, as for benches/hub_fmpy.py (same seed and walk), scaled to 60 MW.
- horizon: the full day by default (20 min or more on the 2-core dev machine); --hours H < 24
  extrapolates, which gives only a lower bound (below).
- timed: the Supervisor.run_control loop (the loop inside the package's run_electrolyzer),
  in process; building the plant (curve fits) and the reference are excluded.

The stacks append each step's voltage, degradation and input power to numpy arrays
(np.append, a full copy each step), two of which are never reset, so the cost of a step grows
with simulated time; the first hours look flat (about 20 s an hour here), so a shorter horizon,
extrapolated with a fit a + b*hour of the per-hour wall times, UNDERESTIMATES the day (4 h gave
485 s, the full day 1177 s). The output says EXTRAPOLATED when it is.
"""

import argparse
import os
import platform
from pathlib import Path
import time

import numpy as np
from electrolyzer.simulation.supervisor import Supervisor
from electrolyzer.tools.design.optimization import calc_rated_system
from electrolyzer.tools.validation import load_modeling_yaml

from wind_reference import wind_reference  # benches/, the script's own folder

DAY, N_STACKS, PLANT_MW = 86_400, 60, 60.0


def plant(control, initial_power_w):
    options = load_modeling_yaml(
        {  # fills in the schema's defaults
            "electrolyzer": {
                "dt": 1.0,
                "initialize": True,
                "initial_power_kW": initial_power_w / 1e3,
                "supervisor": {"system_rating_MW": PLANT_MW, "n_stacks": N_STACKS},
                "controller": {"control_type": control},
                "stack": {
                    "cell_type": "PEM",
                    "max_current": 2000,
                    "temperature": 60,
                    "n_cells": 100,
                    "stack_rating_kW": 1000,
                },
            }
        }
    )
    options = calc_rated_system(options)
    return Supervisor.from_dict(options["electrolyzer"]), options["electrolyzer"]["stack"]


def hardware():
    model = platform.processor() or "?"
    try:
        with open("/proc/cpuinfo") as f:
            model = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    load = " ".join(open("/proc/loadavg").read().split()[:3]) if os.path.exists("/proc/loadavg") else "?"
    return f"{model}, {os.cpu_count()} cores, load average {load}, Python {platform.python_version()}"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--hours",
        type=float,
        default=24.0,
        help="simulated horizon (default the full day, 20 min or more here); < 24 extrapolates to a day, a lower bound",
    )
    parser.add_argument("--control", default="DecisionControl", help="the Supervisor's control_type")
    parser.add_argument(
        "--reference",
        type=Path,
        help="the plant's power reference [W] at 1 s, little-endian f64 (benches/study_bench.py "
        "gives its wind year); default benches/wind_reference.py's day",
    )
    args = parser.parse_args()
    n = int(round(args.hours * 3600))
    if args.reference:
        reference = np.fromfile(args.reference, dtype="<f8", count=n)
    else:
        reference = wind_reference(DAY, PLANT_MW * 1e6)[:n]

    elec, stack = plant(args.control, reference[0])
    print(
        f"NREL electrolyzer {version()}: {elec.n_stacks} PEM stacks of {elec.stack_rating_kW:.1f} kW "
        f"({stack['n_cells']} cells, {stack['max_current']:.0f} A max), control {args.control}, dt 1 s"
    )
    print(f"  on {hardware()}")

    h2 = absorbed = curtailed = 0.0
    hour_s, t0 = [], time.perf_counter()
    start, cpu = t0, time.process_time()
    for k, p in enumerate(reference):
        kg, _, power_left, curt = elec.run_control(p)
        h2 += kg
        curtailed += curt
        # the model's own balance: stack inputs minus what they did not use
        absorbed += sum(s.power_input_history[-1] for s in elec.stacks) - power_left
        if (k + 1) % 3600 == 0 or k + 1 == n:
            now = time.perf_counter()
            hour_s.append(now - t0)
            t0 = now
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu

    ref_mwh = reference.sum() / 3.6e9
    if n >= DAY:
        per_day, how = seconds, "measured"
    else:
        full = [s for s in hour_s if s > 0][: int(n // 3600)] or [seconds]
        if len(full) >= 2:  # per-hour cost a + b*hour (np.append copies grow with time)
            b, a = np.polyfit(np.arange(len(full)), full, 1)
            b = max(b, 0.0)
            per_day = sum(a + b * h for h in range(24))
        else:
            per_day = seconds * DAY / n
        how = f"EXTRAPOLATED, a lower bound, from {args.hours:g} h: {seconds:.1f} s, per hour {', '.join(f'{s:.1f}' for s in hour_s)} s"
    print(
        f"  {args.hours:g} h: reference {ref_mwh:.2f} MWh, absorbed {absorbed / 3.6e9:.2f} MWh, "
        f"curtailed {curtailed / 3.6e9:.2f} MWh, H2 {h2:.0f} kg"
    )
    print(f"nrel: {per_day:.1f} s/day ({how}; CPU {cpu:.1f} s of {seconds:.1f} s wall)")


def version():
    import electrolyzer

    return electrolyzer.__version__


if __name__ == "__main__":
    main()  # runs in the peer's own environment (.venv-nrel), without this package
