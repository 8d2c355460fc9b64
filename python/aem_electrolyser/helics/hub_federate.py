#!/usr/bin/env python3
"""Hub federate: a hub of AEM modules, the packaged FMU driven through fmpy (aem_electrolyser.hub.driver).

    python -m aem_electrolyser.helics.hub_federate [--modules 25000] [--dispatch equal|sequential] [--fmu PATH]
                           [--duration 3600] [--out out/helics] [HELICS options]

The FMU runs with powerInput = true: the wind farm's power is its powerReference [W].
HELICS gives a federate that does not wait for the others at a time (this one) a value published
at t at its next grant, so at grant t it receives w(t - 1 s) and v(t - 1 s), exactly the inputs
of the step it has to take:

* t = 0: receives w(0) (published by the wind in initializing mode) and initialises the FMU in
  steady state for it;
* t >= 1 s: holds powerReference = w(t - 1 s) over [t - 1 s, t] (one doStep of 1 s);

then publishes the FMU's outputs at t: hub/hubPower [W], hub/hubEnergy [J] (over [0, t]),
hub/hubH2Produced [kg] (over [0, t]) and hub/hubH2MassFlow [kg/h]; the FMU gives hydrogen in
normal litres, converted with the factor of its own display unit kg. The bus voltage
grid/voltage [pu] is recorded, not used. The sequence is aem_electrolyser.examples.wind_hub's, so the outputs
are those of the FMU driven alone with the same reference. Records <out>/hub_published.csv and
<out>/hub_received.csv; the log (the FMU's messages among it) goes to stderr, a report to stdout.
"""

import math

from aem_electrolyser.cli import add_fmu_option, one_of, positive, resolve_fmu, writable_folder
from aem_electrolyser.hub.dispatch import DISPATCHES, N_MODULES
from aem_electrolyser.helics import options
from aem_electrolyser.helics.federate import Federate, report_stream, run_federate
from aem_electrolyser.hub.driver import HubFMU
from aem_electrolyser.hub.units import kg_per_nl


def main():
    p = options.parser(__doc__)
    add_fmu_option(p)
    p.add_argument(
        "--modules",
        "--n-modules",
        dest="n_modules",
        type=positive(int),
        default=N_MODULES,
        help=f"modules in the hub [default: {N_MODULES}]",
    )
    p.add_argument(
        "--dispatch",
        type=one_of(sorted(DISPATCHES)),
        default="equal",
        help="equal (every module the same share, stay at the minimum) or sequential (as few "
        "modules as possible, the others in standby) [default: equal]",
    )
    args, helics_args = options.parse(p)
    args.fmu = resolve_fmu(p, args)
    writable_folder(args.out)
    report = report_stream()
    kg = kg_per_nl(args.fmu)
    with (
        Federate(options.HERE / "hub.json", args, helics_args) as fed,
        HubFMU(
            args.fmu, instance_name="hub", nModules=args.n_modules, powerInput=True, **DISPATCHES[args.dispatch]
        ) as hub,
    ):
        fed.enter_executing()
        for t in fed.times():
            u = fed.receive(t)
            if math.isnan(u["powerReference"]):
                raise RuntimeError(f"no wind power received at t={t:g} s")
            if t == 0:
                hub.initialize(powerReference=u["powerReference"])
            else:
                hub.step(1.0, powerReference=u["powerReference"])
            assert hub.time == t, (hub.time, t)
            power, energy, h2, h2_flow = hub.get("hubPower", "hubEnergy", "hubH2Produced", "hubH2MassFlow")
            fed.publish(t, hubPower=power, hubEnergy=energy, hubH2Produced=h2 * kg, hubH2MassFlow=h2_flow)
        elapsed = fed.elapsed()
        fed.log(f"hub energy {energy / 3.6e9:.3f} MWh, hydrogen {h2 * kg:.1f} kg")
    print(
        f"hub: {args.duration} s simulated in {elapsed:.1f} s ({args.n_modules} modules, {args.dispatch} "
        f"dispatch): {energy / 3.6e9:.3f} MWh, {h2 * kg:.1f} kg H2; wrote {args.out / 'hub_published.csv'}",
        file=report,
    )


if __name__ == "__main__":
    run_federate(main)
