#!/usr/bin/env python3
"""Wind federate: the seeded 64 MW offshore wind farm of aem_electrolyser.wind.farm (8 x 8 MW, 1 s).

    python -m aem_electrolyser.helics.wind_federate [--seed 1] [--duration 3600] [--out out/helics] [HELICS options]

Publishes wind/power [W] = w(t), the farm power of farm_power(duration + 1 s, seed) (the series
aem_electrolyser.examples.wind_hub uses for the same duration and seed), at every grant t = 0, 1, ...,
duration [s], and w(0) once more in initializing mode so that the hub can start from it at t = 0.
Receives grid/voltage [pu], the voltage of the bus it feeds (at t the value published at t - 1 s;
recorded, no control uses it yet). It also keeps the wind in step with the others: without an
input it would run ahead, finish and leave, and once a federate has left, HELICS takes a core
that goes silent later for one that disconnected, not for a lost one.
Records <out>/wind_published.csv and <out>/wind_received.csv; its log goes to stderr, a one-line
report to stdout.
"""

from aem_electrolyser.cli import non_negative, writable_folder
from aem_electrolyser.helics import options
from aem_electrolyser.helics.federate import Federate, report_stream, run_federate
from aem_electrolyser.wind.farm import farm_power


def main():
    p = options.parser(__doc__)
    p.add_argument("--seed", type=non_negative(int), default=1, help="seed of the wind series [default: 1]")
    args, helics_args = options.parse(p)
    writable_folder(args.out)
    report = report_stream()
    _, wind, _ = farm_power(args.duration + 1.0, 1.0, seed=args.seed)  # w(t) [W], t = 0..duration
    with Federate(options.HERE / "wind.json", args, helics_args) as fed:
        fed.enter_initializing()
        fed.publish_initial(power=wind[0])
        fed.enter_executing()
        for t in fed.times():
            fed.receive(t)
            fed.publish(t, power=wind[int(t)])
        elapsed = fed.elapsed()
        fed.log(f"published {len(wind)} values, mean {wind.mean() / 1e6:.3f} MW")
    print(
        f"wind: {args.duration} s simulated in {elapsed:.1f} s, mean power "
        f"{wind.mean() / 1e6:.2f} MW; wrote {args.out / 'wind_published.csv'}",
        file=report,
    )


if __name__ == "__main__":
    run_federate(main)
