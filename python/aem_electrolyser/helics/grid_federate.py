#!/usr/bin/env python3
"""Grid federate: pandapower's CIGRE HV benchmark grid with the wind farm and the hub at one bus.

    python -m aem_electrolyser.helics.grid_federate [--bus "Bus 1"] [--duration 3600] [--out out/helics] [HELICS options]

pandapower.networks.create_cigre_network_hv() with, at the bus, a static generator "wind"
(p = wind/power) and a load "hub" (p = hub/hubPower), both at unity power factor. Its config
sets wait_for_current_time_update: HELICS grants it t only after the wind and the hub have
finished t, so the load flow at t sees w(t) and hubPower(t), published at t. At every grant t it
runs the load flow (Newton-Raphson to 1e-8 MVA, started from the previous solution, matrices
reused: only bus powers change) and publishes grid/voltage [pu], the bus's voltage magnitude,
and grid/slackPower [W], the active power drawn from the external grid (the slack, Generator 9).

Bus 1 is the host, as in aem_electrolyser.mosaik: Bus 5 cannot take the hub, 60 MW with no wind pull
it to 0.890 pu (the benchmark already has Bus 4 at 0.951 pu); at Bus 1 every combination of
0/64 MW wind and 0/60 MW hub keeps all buses within 0.951-1.044 pu and lines below 79 %.
Records <out>/grid_published.csv and <out>/grid_received.csv; log to stderr, report to stdout.
"""

import time

from aem_electrolyser.cli import did_you_mean, writable_folder
from aem_electrolyser.extras import needs
from aem_electrolyser.helics import options
from aem_electrolyser.helics.federate import Federate, report_stream, run_federate

with needs("helics", __name__):
    import pandapower as pp
    import pandapower.networks as pn

HOST_BUS = "Bus 1"


def grid(bus_name=HOST_BUS):
    """(net, wind sgen index, hub load index, bus index) with wind and hub at 0 MW."""
    net = pn.create_cigre_network_hv()
    matches = net.bus.index[net.bus.name == bus_name]
    if len(matches) != 1:
        raise ValueError(
            f"{bus_name!r} is not a bus of the CIGRE HV grid ({', '.join(net.bus.name)})"
            f"{did_you_mean(bus_name, list(net.bus.name))}"
        )
    bus = int(matches[0])
    return net, pp.create_sgen(net, bus, p_mw=0.0, name="wind"), pp.create_load(net, bus, p_mw=0.0, name="hub"), bus


def solve(net, first):
    """Load flow; the first from pandapower's default start, then from the previous solution."""
    if first:
        pp.runpp(net, numba=False)
    else:
        pp.runpp(net, numba=False, init="results", recycle=dict(bus_pq=True, trafo=False, gen=False))


def main():
    p = options.parser(__doc__)
    p.add_argument("--bus", default=HOST_BUS, help=f"the bus of the wind farm and the hub [default: {HOST_BUS}]")
    args, helics_args = options.parse(p)
    try:
        net, wind, hub, bus = grid(args.bus)
    except ValueError as e:
        p.error(f"argument --bus: {e}")
    writable_folder(args.out)
    report = report_stream()
    solving = 0.0  # wall time in load flows [s]
    with Federate(options.HERE / "grid.json", args, helics_args) as fed:
        fed.enter_executing()
        for t in fed.times():
            u = fed.receive(t)
            if any(v != v for v in u.values()):
                raise RuntimeError(f"no value received at t={t:g} s: {u}")
            net.sgen.at[wind, "p_mw"] = u["windPower"] / 1e6
            net.load.at[hub, "p_mw"] = u["hubPower"] / 1e6
            start = time.perf_counter()
            solve(net, first=(t == 0))
            solving += time.perf_counter() - start
            fed.publish(t, voltage=net.res_bus.at[bus, "vm_pu"], slackPower=net.res_ext_grid.p_mw.sum() * 1e6)
        elapsed, vmin = fed.elapsed(), net.res_bus.vm_pu.min()
    print(
        f"grid: {args.duration} s simulated in {elapsed:.1f} s (load flows {solving:.1f} s), {args.bus} at the end "
        f"{net.res_bus.at[bus, 'vm_pu']:.4f} pu (lowest bus {vmin:.4f} pu); wrote {args.out / 'grid_published.csv'}",
        file=report,
    )


if __name__ == "__main__":
    run_federate(main)
