#!/usr/bin/env python3
"""A 60 MW electrolyser hub and a 64 MW offshore wind farm at Bus 1 of the CIGRE HV benchmark
grid, co-simulated in mosaik 3 with pandapower (1 s steps).

    python -m aem_electrolyser.mosaik.cigre_scenario [--duration 3600] [--seed 1]
                                                     [--dispatch equal|sequential] [--out out]

Simulators, all in this process (mosaik's "python" starter; no network, not even loopback):

* Wind: mosaik-csv reading the seeded 1 s series of aem_electrolyser.wind.farm (8 x 8 MW, rounded to
  1 W so that the CSV round trip is exact), attribute P[W].
* AEM: aem_electrolyser.mosaik.simulator, one Hub of 25 000 modules (powerInput = true; dispatch
  equal, or sequential with standby below the minimum, as aem_electrolyser.examples.wind_hub).
* Grid: mosaik-pandapower-2 on pandapower's create_cigre_network_hv(). The wind farm and the hub
  are the static generator and the load that mosaik-pandapower-2 attaches to every bus for
  inputs to the Bus attributes P_gen[MW] and P_load[MW] (unity power factor). The subclass
  CigreGrid adds what the balance checks need: the grid's totals as Grid attributes, the solved
  power of the bus's load and static generator as Bus outputs, and runpp with recycled matrices
  and the previous solution as start (3x faster; every step still converges to 1e-8 MVA).
* Recorder: mosaik's OutputSimulator, keeping every value by time (time-based here).

Data flow and timing, with t = 0, 1, ..., duration [s] (duration + 1 samples): Wind gives w(t);
the Hub gets powerReference = w(t) and the Grid's Bus 1 gets P_gen[MW] = w(t)/1e6. The Hub's
outputs at t are the FMU's state at t: initialised in steady state for w(0), then advanced from
t-1 to t with w(t-1) held over the step (aem_electrolyser.hub.driver's convention); its hubPower(t)/1e6
is Bus 1's P_load[MW] at t, so the load flow at t sees the wind and the hub at the same instant.
The hub's energy over [0, duration] is hubEnergy(duration).

Signs: hubPower [W] is consumption, so hubPower/1e6 goes to P_load[MW] (consumer convention,
as pandapower's loads); the wind is P_gen[MW] (generator convention, as its static generators).

The bus. Limits: 0.95 <= vm <= 1.05 pu at every bus, loading <= 100 % on every line and
transformer. The benchmark's own operating point already has Bus 4 at 0.951 pu, so the host must
not weaken the 220 kV ring's far end (Buses 4 and 5). hosting_check runs the hub at 0 or 60 MW
with the wind at 0 or 64 MW: at Bus 1 (220 kV, fed from the external grid through the
1000 MVA transformer 9-1 and tied to the 380 kV ring by 1-7) every combination stays inside:
0.9510 to 1.0440 pu, lines <= 78.4 %, transformers <= 68.1 %. Placed at Bus 3, 4, 5, 6a, 6b or
8 (or at the generator buses 11 and 12), the hub without wind pulls Bus 5 below 0.95 pu (to
0.89 pu when placed at Bus 5); placed at Bus 2 or 10, the wind without the hub does (0.947 pu).
The 380 kV Bus 7 would do with less margin (0.9506 pu); Bus 9 is the external grid's own 22 kV
bus. So Bus 1: a strong bus, where a wind farm and an electrolyser absorbing it would connect.

Writes <out>/mosaik_cigre.csv (a row per sample t with the values at t, hub energy and H2 accumulated over
[0, t]; units in the headers) and mosaik_cigre.png, then prints a summary.
"""

import sys

from aem_electrolyser import cli
from aem_electrolyser.extras import require
from aem_electrolyser.hub.dispatch import DISPATCHES


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(parser)
    parser.add_argument(
        "--duration", type=cli.positive(int), default=3600, help="simulated seconds, at least 2 [default: 3600]"
    )
    parser.add_argument("--seed", type=int, default=1, help="wind series seed [default: 1]")
    parser.add_argument(
        "--dispatch",
        type=cli.one_of(list(DISPATCHES)),
        default="equal",
        help=f"{' or '.join(DISPATCHES)} [default: equal]",
    )
    cli.add_out_option(parser, "out", "mosaik_cigre.csv and mosaik_cigre.png")
    args = parser.parse_args(argv)
    require("mosaik", cli.program_name())
    if args.duration < 2:
        parser.error(f"--duration: {args.duration} s; it must be at least 2 s")
    args.fmu = cli.resolve_fmu(parser, args)
    cli.writable_folder(args.out)
    # mosaik and pandapower (seconds to import) once the arguments are known good
    from loguru import logger

    from aem_electrolyser.mosaik.cigre import run

    # mosaik's and the simulator's log (loguru): warnings on stderr, everything with --debug
    logger.remove()
    logger.add(sys.stderr, level="DEBUG" if args.debug else "WARNING")
    run(args.fmu, args.duration, args.seed, args.dispatch, args.out, verbose=not args.quiet, quiet=args.quiet)


if __name__ == "__main__":
    cli.run_command(main)
