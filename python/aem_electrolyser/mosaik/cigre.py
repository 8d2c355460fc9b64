"""The CIGRE scenario in mosaik 3: its simulators (CigreGrid, the recorder), the bus check
(hosting_check), the run (simulate, run) and its files. The command and its documentation:
aem_electrolyser.mosaik.cigre_scenario (`python -m aem_electrolyser.mosaik.cigre_scenario --help`)."""

import copy
import csv
import tempfile
import time as clock
from pathlib import Path

import numpy as np


from aem_electrolyser import cli
from aem_electrolyser.extras import needs
from aem_electrolyser.hub.dispatch import DISPATCHES, N_MODULES
from aem_electrolyser.hub.units import kg_per_nl
from aem_electrolyser.locate import fmu_path
from aem_electrolyser.wind.farm import farm_power

with needs("mosaik", __name__):
    import mosaik
    import pandapower as pp
    import pandapower.networks as pn
    from mosaik.basic_simulators import OutputSimulator
    from mosaik.starters import PythonStarter
    from mosaik_components.pandapower import Simulator as PandapowerSimulator
    from mosaik_components.pandapower.simulator import MODEL_TO_ELEMENT_SPECS

HOST_BUS = "Bus 1"
HUB_OUT = ["hubPower", "powerReference", "hubEnergy", "hubH2Produced", "modulesRunning", "modulesStandby"]
STEP = 1  # communication step of every simulator [s] (mosaik time resolution 1 s)
START = "2026-01-01 00:00:00"  # mosaik-csv needs dates; only the offsets matter


class CigreGrid(PandapowerSimulator):
    """mosaik-pandapower-2's simulator with, in addition:

    * Grid attributes, sums over pandapower's result tables [MW, %]: P_load, P_sgen, P_gen,
      P_shunt, P_ext_grid (consumer or generator sign as the tables), P_loss_line, P_loss_trafo,
      loading_trafo_max;
    * Bus outputs P_load[MW] and P_gen[MW]: the solved power of the load and static generator
      that the bus's inputs of the same names set;
    * runpp with recycle (only bus P/Q change) and init from the previous results.
    """

    TOTALS = {
        "P_load[MW]": ("res_load", "p_mw"),
        "P_sgen[MW]": ("res_sgen", "p_mw"),
        "P_gen[MW]": ("res_gen", "p_mw"),
        "P_shunt[MW]": ("res_shunt", "p_mw"),
        "P_ext_grid[MW]": ("res_ext_grid", "p_mw"),
        "P_loss_line[MW]": ("res_line", "pl_mw"),
        "P_loss_trafo[MW]": ("res_trafo", "pl_mw"),
    }
    BUS_ELEMENT = {"P_load[MW]": "load", "P_gen[MW]": "sgen"}

    def __init__(self):
        super().__init__()
        self.meta = copy.deepcopy(self.meta)
        self.meta["models"]["Grid"]["attrs"] = [*self.TOTALS, "loading_trafo_max[%]"]

    def step(self, time, inputs, max_advance):
        assert not self._profiles, "profiles are not applied by this subclass"
        for eid, data in inputs.items():  # written as mosaik-pandapower-2 does
            model, idx = self.get_model_and_idx(eid)
            spec = MODEL_TO_ELEMENT_SPECS[model]
            for attr, values in data.items():
                a = spec.input_attr_specs[attr]
                self._net[a.target_elem or spec.elem].at[a.idx_fn(idx, self), a.column] = a.aggregator(values.values())
        pp.runpp(self._net, numba=pp.NUMBA_INSTALLED, init="results", recycle=dict(bus_pq=True, trafo=False, gen=False))
        return time + self._step_size if self._step_size else None

    def get_entity_data(self, eid, attrs):
        net = self._net
        if eid == "Grid":
            out = {a: float(net[self.TOTALS[a][0]][self.TOTALS[a][1]].sum()) for a in attrs if a in self.TOTALS}
            if "loading_trafo_max[%]" in attrs:
                out["loading_trafo_max[%]"] = float(net.res_trafo.loading_percent.max())
            return out
        model, idx = self.get_model_and_idx(eid)
        extra = [a for a in attrs if model == "Bus" and a in self.BUS_ELEMENT]
        out = super().get_entity_data(eid, [a for a in attrs if a not in extra])
        for a in extra:
            element = self.BUS_ELEMENT[a]
            out[a] = float(net[f"res_{element}"].at[self.bus_auto_elements.at[idx, element], "p_mw"])
        return out


class Recorder(OutputSimulator):
    """mosaik's OutputSimulator (inputs kept by time, get_dict), stepped every step_size ticks:
    as an event-based simulator mosaik 3.6 leaves one waiting future per step in its progress,
    and the run slows down quadratically (an hour took twice as long)."""

    def init(self, sid, time_resolution=1.0, step_size=1):
        self.step_size = step_size
        self.meta = {**self.meta, "type": "time-based"}
        return self.meta

    def step(self, time, inputs, max_advance):
        super().step(time, inputs, max_advance)
        return time + self.step_size


def hosting_check(bus_name=HOST_BUS, hub_mw=(0.0, 60.0), wind_mw=(0.0, 64.0)):
    """Worst (lowest vm [pu], highest vm [pu], highest line and trafo loading [%]) of the CIGRE HV
    grid over every combination of a load of hub_mw and a static generator of wind_mw [MW] at
    the bus."""
    worst = [np.inf, -np.inf, -np.inf, -np.inf]
    for load in hub_mw:
        for gen in wind_mw:
            net = pn.create_cigre_network_hv()
            bus = int(net.bus.index[net.bus.name == bus_name][0])
            pp.create_load(net, bus, p_mw=load)
            pp.create_sgen(net, bus, p_mw=gen)
            pp.runpp(net, numba=pp.NUMBA_INSTALLED)
            worst = [
                min(worst[0], net.res_bus.vm_pu.min()),
                max(worst[1], net.res_bus.vm_pu.max()),
                max(worst[2], net.res_line.loading_percent.max()),
                max(worst[3], net.res_trafo.loading_percent.max()),
            ]
    return tuple(float(x) for x in worst)


def wind_series(duration, seed):
    """(time [s], farm power [W] rounded to 1 W) at 0, 1, ..., duration."""
    t, wind, _ = farm_power(duration + STEP, STEP, seed=seed)
    return t, np.round(wind)


def write_wind_csv(path, t, wind):
    """mosaik-csv's format: model name, header, one dated row per sample."""
    dates = np.datetime64(START) + t.astype("timedelta64[s]")
    with open(path, "w", newline="") as f:
        f.write("Wind\n")
        w = csv.writer(f)
        w.writerow(["Date", "P[W]"])
        for d, p in zip(dates, wind):
            w.writerow([str(d).replace("T", " "), f"{p:.0f}"])


def simulate(fmu=None, duration=3600, seed=1, dispatch="equal", quiet=True):
    """Run the co-simulation; returns a dict of arrays [SI units, MW, pu, %] keyed by name.
    mosaik draws its progress bar (tqdm) unless quiet."""
    fmu = fmu_path(fmu)
    t, wind = wind_series(duration, seed)
    net = pn.create_cigre_network_hv()
    host = int(net.bus.index[net.bus.name == HOST_BUS][0])
    sim_config = {
        "Wind": {"python": "mosaik_csv:CSV"},
        "AEM": {"python": "aem_electrolyser.mosaik.simulator:AemSimulator"},
        "Grid": PythonStarter(CigreGrid),
        "Recorder": PythonStarter(Recorder),
    }
    with (
        tempfile.TemporaryDirectory() as tmp,
        mosaik.World(sim_config, time_resolution=1.0, skip_greetings=True, configure_logging=False) as world,
    ):
        write_wind_csv(Path(tmp) / "wind.csv", t, wind)
        wind_farm = world.start("Wind", sim_id="Wind", sim_start=START, datafile=str(Path(tmp) / "wind.csv")).Wind()
        hub = world.start("AEM", sim_id="AEM", fmu=str(fmu), step_size=float(STEP)).Hub(
            nModules=N_MODULES, powerInput=True, **DISPATCHES[dispatch]
        )
        grid_sim = world.start("Grid", sim_id="Grid", step_size=STEP)
        grid = grid_sim.Grid(net=net)
        by_id = {e.eid: e for e in grid.children}
        buses = [by_id[f"Bus-{i}"] for i in net.bus.index]
        lines = [by_id[f"Line-{i}"] for i in net.line.index]
        recorder_sim = world.start("Recorder", sim_id="Recorder", step_size=STEP)
        rec = recorder_sim.Dict()

        world.connect(wind_farm, hub, ("P[W]", "powerReference"))
        world.connect(wind_farm, buses[host], ("P[W]", "P_gen[MW]"), transform=lambda w: w / 1e6)
        world.connect(hub, buses[host], ("hubPower", "P_load[MW]"), transform=lambda w: w / 1e6)
        world.connect(hub, rec, *HUB_OUT)
        world.connect(buses[host], rec, "P_load[MW]", "P_gen[MW]")
        for b in buses:
            world.connect(b, rec, "Vm[pu]")
        for line in lines:
            world.connect(line, rec, "loading[%]")
        world.connect(grid, rec, *CigreGrid.TOTALS, "loading_trafo_max[%]")
        world.run(until=duration + 1, print_progress=cli.shows_progress(quiet))
        records = recorder_sim.get_dict(rec.eid)

    times = sorted(records)
    series = lambda src, attr: np.array([records[k][attr][src.full_id] for k in times], dtype=float)  # noqa: E731
    out = {"time": np.array(times, dtype=float), "wind series": wind}
    out.update({name: series(hub, name) for name in HUB_OUT})
    out["hub load in grid"] = series(buses[host], "P_load[MW]")
    out["wind in grid"] = series(buses[host], "P_gen[MW]")
    out.update({a: series(grid, a) for a in [*CigreGrid.TOTALS, "loading_trafo_max[%]"]})
    out["vm"] = {net.bus.name[i]: series(b, "Vm[pu]") for i, b in zip(net.bus.index, buses)}
    out["loading"] = {net.line.name[i]: series(line, "loading[%]") for i, line in zip(net.line.index, lines)}
    return out


def write_csv(path, r, kg):
    columns = {
        "time [s]": r["time"],
        "wind power [MW]": r["wind in grid"],
        "hub power reference [MW]": r["powerReference"] / 1e6,
        "hub power [MW]": r["hubPower"] / 1e6,
        "hub load in grid [MW]": r["hub load in grid"],
        "hub energy [MWh]": r["hubEnergy"] / 3.6e9,
        "hub H2 [kg]": r["hubH2Produced"] * kg,
        "modules running [1]": r["modulesRunning"],
        "modules standby [1]": r["modulesStandby"],
    }
    columns.update({f"vm {bus} [pu]": v for bus, v in r["vm"].items()})
    columns.update({f"loading {line} [%]": v for line, v in r["loading"].items()})
    columns.update(
        {
            "slack power [MW]": r["P_ext_grid[MW]"],
            "loads [MW]": r["P_load[MW]"],
            "static generators [MW]": r["P_sgen[MW]"],
            "generators [MW]": r["P_gen[MW]"],
            "shunts [MW]": r["P_shunt[MW]"],
            "line losses [MW]": r["P_loss_line[MW]"],
            "trafo losses [MW]": r["P_loss_trafo[MW]"],
            "max trafo loading [%]": r["loading_trafo_max[%]"],
        }
    )
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for row in zip(*columns.values()):
            w.writerow([f"{x:.12g}" for x in row])


def plot(path, r, dispatch):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tm = r["time"] / 60.0
    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    ax[0].plot(tm, r["wind in grid"], color="tab:gray", lw=1, label="wind farm (static generator)")
    ax[0].plot(tm, r["hub load in grid"], color="tab:blue", lw=1, label=f"hub (load), {dispatch} dispatch")
    ax[0].set_ylabel("power [MW]")
    ax[1].plot(
        tm,
        r["wind in grid"] - r["hub load in grid"],
        color="tab:green",
        lw=1,
        label=f"wind - hub at {HOST_BUS} (export)",
    )
    ax[1].plot(
        tm,
        r["P_ext_grid[MW]"] - r["P_ext_grid[MW]"][0],
        color="tab:red",
        lw=1,
        ls="--",
        label=f"slack power - {r['P_ext_grid[MW]'][0]:.1f} MW",
    )
    ax[1].set_ylabel("power [MW]")
    for bus in (HOST_BUS, "Bus 7", "Bus 5", "Bus 4"):
        v = r["vm"][bus]
        ax[2].plot(tm, 1e3 * (v - v[0]), lw=1, label=f"{bus} (from {v[0]:.4f} pu)")
    ax[2].set_ylabel("voltage change [mpu]")
    for line in ("Line 1-2", "Line 1-6a", "Line 7-8", "Line 6a-6b"):
        v = r["loading"][line]
        ax[3].plot(tm, v - v[0], lw=1, label=f"{line} (from {v[0]:.1f} %)")
    ax[3].set_ylabel("line loading change [% pt]")
    ax[3].set_xlabel("time [min]")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7, ncol=2, loc="best")
    fig.suptitle(f"{N_MODULES} AEM modules and a 64 MW wind farm at {HOST_BUS} of the CIGRE HV grid (mosaik)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def run(fmu=None, duration=3600, seed=1, dispatch="equal", out=None, verbose=True, quiet=True):
    """Simulate; write <out>/mosaik_cigre.csv and .png when the folder `out` is given; print a
    summary when verbose; a progress bar unless quiet."""
    fmu = fmu_path(fmu)
    started = clock.perf_counter()
    r = simulate(fmu, duration, seed, dispatch, quiet)
    wall = clock.perf_counter() - started
    kg = kg_per_nl(fmu)
    if out is not None:
        out = Path(out) / "mosaik_cigre"
        out.parent.mkdir(parents=True, exist_ok=True)
        write_csv(out.with_suffix(".csv"), r, kg)
        plot(out.with_suffix(".png"), r, dispatch)
    if verbose:
        vmin = {bus: v.min() for bus, v in r["vm"].items()}
        low = min(vmin, key=vmin.get)
        lmax = {line: v.max() for line, v in r["loading"].items()}
        high = max(lmax, key=lmax.get)
        print(
            f"{duration:.0f} s at 1 s in mosaik {mosaik.__version__} ({wall:.1f} s wall): wind farm "
            f"{r['wind series'][:-1].sum() / 3.6e9:.2f} MWh, hub of {N_MODULES} modules ({dispatch}) "
            f"{(r['hubEnergy'][-1] - r['hubEnergy'][0]) / 3.6e9:.2f} MWh, "
            f"{(r['hubH2Produced'][-1] - r['hubH2Produced'][0]) * kg:.1f} kg H2"
        )
        export = r["wind in grid"] - r["hub load in grid"]
        slack = r["P_ext_grid[MW]"]
        print(
            f"{HOST_BUS} of the CIGRE HV grid: wind - hub {export.min():.2f} to {export.max():.2f} MW, slack "
            f"{slack.min():.1f} to {slack.max():.1f} MW; lowest voltage {vmin[low]:.4f} pu ({low}), "
            f"highest line loading {lmax[high]:.1f} % ({high})"
        )
        if out is not None:
            print(f"wrote {out.with_suffix('.csv')} and {out.with_suffix('.png')}")
    return r, wall
