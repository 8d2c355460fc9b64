"""The hub FMU in mosaik 3 (aem_electrolyser.mosaik): its simulator against the FMU driven alone
through fmpy (aem_electrolyser.hub.driver), and ten minutes of cigre_scenario (25 000 modules, 1 s
steps, the CIGRE HV grid in pandapower: 601 exchanges of power and load flows) against conservation
of power and fresh load flows.

Expected values come from the FMU run alone, the wind series recomputed, the FMU's model
description read with ElementTree, or pandapower run without mosaik; none from the simulator."""

import re
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from conftest import ROOT
from commands import assert_quiet, run as run_command

import pandapower as pp
import pandapower.networks as pn

from aem_electrolyser.hub import HubFMU
from aem_electrolyser.mosaik import cigre
from aem_electrolyser.mosaik import simulator as aem_simulator
from aem_electrolyser.mosaik.simulator import AemSimulator, FMUError
from aem_electrolyser.wind.farm import farm_power

SCENARIO = ["-m", "aem_electrolyser.mosaik.cigre_scenario"]
SEED, DURATION, N = 1, 600, 25_000
HUB_OUTPUTS = ["hubPower", "hubEnergy", "hubH2Produced", "modulesRunning", "modulesStandby"]

# mosaik and pandapower: the co-simulation lane of scripts/test.sh
pytestmark = [pytest.mark.cosim]


def alone(fmu, reference, h=1.0, outputs=HUB_OUTPUTS, **parameters):
    """The FMU alone in fmpy: reference[k] [W] held over [k h, (k+1) h); outputs at k h, k = 0..len."""
    with HubFMU(fmu, **parameters) as hub:
        hub.initialize(powerReference=reference[0])
        rows = []
        for k in range(len(reference) + 1):
            rows.append(hub.get(*outputs))
            if k < len(reference):
                hub.step(h, powerReference=reference[k])
    return {name: np.array([row[i] for row in rows], dtype=float) for i, name in enumerate(outputs)}


@pytest.fixture(scope="module")
def wind():
    """The scenario's wind series [W], recomputed: aem_electrolyser.wind.farm rounded to 1 W."""
    return np.round(farm_power(DURATION + 1.0, 1.0, seed=SEED)[1])


@pytest.fixture(scope="module")
def equal_alone(fmu_path, wind):
    """The equal hub of the scenario, alone in fmpy, with the same reference held over the same steps."""
    return alone(fmu_path, wind[:-1], nModules=N, dispatch=1, belowMinimum=0, powerInput=True)


@pytest.fixture(scope="module")
def scenario(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("mosaik")
    r, wall = cigre.run(fmu_path, DURATION, SEED, "equal", out, verbose=False)
    return out / "mosaik_cigre", r, wall


def test_the_scenario_runs_and_writes_its_files(scenario):
    out, r, wall = scenario
    assert np.array_equal(r["time"], np.arange(DURATION + 1.0))
    with open(out.with_suffix(".csv")) as f:
        header = f.readline().rstrip("\n").split(",")
        rows = f.read().splitlines()
    assert len(rows) == DURATION + 1
    assert all(re.fullmatch(r".+ \[(s|MW|MWh|kg|1|pu|%)\]", h) for h in header), header
    assert {
        "time [s]",
        "vm Bus 5 [pu]",
        "loading Line 1-2 [%]",
        "hub power [MW]",
        "hub H2 [kg]",
        "slack power [MW]",
    } <= set(header)
    assert out.with_suffix(".png").stat().st_size > 10_000


def test_power_is_conserved_at_every_step(scenario):
    _, r, _ = scenario
    # slack = loads (the hub's among them) + shunts - static generators (wind) - generators + losses
    residual = r["P_ext_grid[MW]"] - (
        r["P_load[MW]"]
        + r["P_shunt[MW]"]
        - r["P_sgen[MW]"]
        - r["P_gen[MW]"]
        + r["P_loss_line[MW]"]
        + r["P_loss_trafo[MW]"]
    )
    assert np.abs(residual).max() < 1e-6
    fixed = pn.create_cigre_network_hv()
    assert np.allclose(r["P_load[MW]"] - fixed.load.p_mw.sum(), r["hub load in grid"], rtol=0, atol=1e-9)
    assert np.allclose(r["P_sgen[MW]"], r["wind in grid"], rtol=0, atol=1e-9)
    assert np.array_equal(r["P_gen[MW]"], np.full(DURATION + 1, fixed.gen.p_mw.sum()))


def test_the_grid_sees_the_hub_and_the_wind_of_the_same_instant(scenario, wind, equal_alone):
    _, r, _ = scenario
    assert np.array_equal(r["wind in grid"], wind / 1e6)
    assert np.array_equal(r["powerReference"], wind)  # the hub is asked w(t) at t ...
    assert np.array_equal(r["hub load in grid"], equal_alone["hubPower"] / 1e6)  # ... and draws hubPower(t)
    assert np.array_equal(r["hub load in grid"], r["hubPower"] / 1e6)


def test_the_hub_through_mosaik_is_the_fmu_alone_bit_for_bit(scenario, equal_alone, wind):
    _, r, _ = scenario
    for name in HUB_OUTPUTS:
        assert np.array_equal(r[name], equal_alone[name]), name
    # the wind (36…55 MW) stays inside the hub's window (36…60 MW): the hub absorbs its energy, all
    # but what the current dynamics lag behind (0.1 %)
    assert equal_alone["hubEnergy"][-1] == pytest.approx(wind[:-1].sum() * 1.0, rel=5e-3)


@pytest.mark.parametrize("t", [0, 1, 2, 59, 123, 300, 451, 599, 600])
def test_each_load_flow_is_a_fresh_pandapower_load_flow(scenario, t):
    """The recycled, warm-started load flow of the scenario against a flat-start one of the same
    injections on a new net."""
    _, r, _ = scenario
    net = pn.create_cigre_network_hv()
    bus = int(net.bus.index[net.bus.name == "Bus 1"][0])
    pp.create_load(net, bus, p_mw=r["hub load in grid"][t])
    pp.create_sgen(net, bus, p_mw=r["wind in grid"][t])
    pp.runpp(net, numba=pp.NUMBA_INSTALLED)
    assert r["P_ext_grid[MW]"][t] == pytest.approx(net.res_ext_grid.p_mw.sum(), abs=1e-6)
    for i, name in net.bus.name.items():
        assert r["vm"][name][t] == pytest.approx(net.res_bus.vm_pu[i], abs=1e-9), name
    for i, name in net.line.name.items():
        assert r["loading"][name][t] == pytest.approx(net.res_line.loading_percent[i], abs=1e-6), name


def test_bus_1_hosts_the_hub_and_the_wind_within_limits():
    vmin, vmax, line, trafo = cigre.hosting_check("Bus 1")
    assert 0.95 <= vmin and vmax <= 1.05 and line <= 100 and trafo <= 100
    assert cigre.hosting_check("Bus 5")[0] < 0.95  # the weak end of the 220 kV ring would not


def fmu_variables(fmu):
    """name -> (causality, unit or None) from the FMU's modelDescription.xml."""
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    return {v.get("name"): (v.get("causality"), v[0].get("unit")) for v in root.iter("ScalarVariable")}


def started(fmu, **sim_params):
    sim = AemSimulator()
    meta = sim.init("AEM", **{"time_resolution": 1.0, "fmu": str(fmu), **sim_params})
    return sim, meta


def test_meta_has_every_variable_with_its_unit(fmu_path):
    sim, meta = started(fmu_path)
    assert meta["type"] == "time-based"
    hub, module = meta["models"]["Hub"], meta["models"]["Module"]
    variables = fmu_variables(fmu_path)
    assert set(hub["params"]) == {n for n, (c, _) in variables.items() if c == "parameter"}
    assert set(hub["attrs"]) == {n for n, (c, _) in variables.items() if c in ("input", "output")}
    for model in (hub, module):
        assert set(model["units"]) == set(model["params"]) | set(model["attrs"])
        assert all(model["units"][a] for a in model["attrs"])  # every attribute has a unit
        for name in model["units"]:
            if variables[name][1]:
                assert model["units"][name] == variables[name][1], name
    assert hub["units"]["powerReference"] == "W" and hub["units"]["modulesRunning"] == "1"
    assert "nModules" not in module["params"] and "powerReference" not in module["attrs"]
    sim.finalize()


def test_fmu_errors_name_the_entity_and_the_fmus_message(fmu_path):
    sim, _ = started(fmu_path)
    sim.create(1, "Hub", nModules=-5)
    with pytest.raises(FMUError, match=r"Hub_0: .*nModules = -5 is invalid"):
        sim.step(0, {}, 10)
    sim.finalize()
    sim, _ = started(fmu_path)
    sim.create(2, "Hub", nModules=10, powerInput=True)
    sim.step(0, {}, 10)
    with pytest.raises(FMUError, match=r"Hub_1: fmi2SetReal .*powerReference = NaN"):
        sim.step(1, {"Hub_1": {"powerReference": {"Wind.Wind_0": float("nan")}}}, 10)
    sim.finalize()
    assert aem_simulator._LIVE == {}  # every instance freed


MOSAIK_ERROR = """
import sys
import mosaik

cfg = {"AEM": {"python": "aem_electrolyser.mosaik.simulator:AemSimulator"}, "Rec": {"python": "mosaik.basic_simulators:OutputSimulator"}}
with mosaik.World(cfg, skip_greetings=True, configure_logging=False) as world:
    hub = world.start("AEM", fmu=sys.argv[1]).Hub(nModules=-5)
    world.connect(hub, world.start("Rec").Dict(), "hubPower")
    world.run(until=10, print_progress=False)
"""


def test_an_fmu_error_ends_a_mosaik_run_with_the_message_not_a_hang(fmu_path):
    done = subprocess.run(
        [sys.executable, "-c", MOSAIK_ERROR, str(fmu_path)], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 1
    assert "aem_electrolyser.mosaik.simulator.FMUError: Hub_0: fmi2ExitInitializationMode" in done.stderr, done.stderr
    assert "nModules = -5 is invalid" in done.stderr
    assert done.stdout == ""  # the FMU's log is on stderr


def test_a_module_with_half_second_ticks_and_two_second_steps(fmu_path):
    setpoints = [100.0, 70.0, 70.0, 90.0, 40.0, 40.0, 85.0] + [95.0] * 30
    sim, _ = started(fmu_path, time_resolution=0.5, step_size=2.0)
    sim.create(1, "Module", belowMinimum=1)
    got, tick = [], 0
    for u in setpoints:
        assert sim.step(tick, {"Module_0": {"setpoint": {"src": u}}}, 10**6) == tick + 4
        got.append(sim.get_data({"Module_0": ["current", "power", "energy", "operatingState"]})["Module_0"])
        tick += 4
    sim.finalize()
    with HubFMU(fmu_path, nModules=1, belowMinimum=1) as hub:
        hub.initialize(setpoint=setpoints[0])
        for k, u in enumerate(setpoints):
            hub.set(setpoint=u)
            assert list(got[k].values()) == hub.get("current", "power", "energy", "operatingState"), k
            hub.step(2.0)


def enumeration_fmu(fmu, path):
    """The FMU if its dispatch, belowMinimum and operatingState are FMI Enumerations, else a copy
    of it where they are."""
    items = {
        "Dispatch": ["equal", "sequential", "rotation"],
        "BelowMinimum": ["stayAtMinimum", "standby", "off"],
        "OperatingState": ["idle", "starting", "running", "standby", "stopping"],
    }
    first = {"Dispatch": 1, "BelowMinimum": 0, "OperatingState": 0}
    types = "".join(
        f'<SimpleType name="{t}"><Enumeration>'
        + "".join(f'<Item name="{n}" value="{first[t] + i}"/>' for i, n in enumerate(names))
        + "</Enumeration></SimpleType>"
        for t, names in items.items()
    )
    with zipfile.ZipFile(fmu) as z:
        files = {n: z.read(n) for n in z.namelist()}
    xml = files["modelDescription.xml"].decode()
    if '<Enumeration declaredType="Dispatch"' in xml:
        return fmu
    xml = xml.replace("<LogCategories>", f"<TypeDefinitions>{types}</TypeDefinitions>\n  <LogCategories>", 1)
    for name, t in [("dispatch", "Dispatch"), ("belowMinimum", "BelowMinimum"), ("operatingState", "OperatingState")]:
        xml, n = re.subn(
            rf'(name="{name}".*?)<Integer', rf'\1<Enumeration declaredType="{t}"', xml, count=1, flags=re.S
        )
        assert n == 1
    files["modelDescription.xml"] = xml.encode()
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for n, data in files.items():
            z.writestr(n, data)
    return path


def test_enumerations_are_set_and_got_as_integers(fmu_path, tmp_path, wind):
    enum_fmu = enumeration_fmu(fmu_path, tmp_path / "Enum.fmu")
    sim, meta = started(enum_fmu)
    assert meta["models"]["Hub"]["units"]["dispatch"] == "1"
    assert meta["models"]["Hub"]["enumerations"]["dispatch"] == {
        "equal": 1,
        "sequential": 2,
        "rotation": 3,
        "target": 4,
    }
    sim.create(1, "Hub", nModules=N, dispatch="sequential", belowMinimum="standby", powerInput=True)
    sim.create(1, "Hub", nModules=N, dispatch=2, belowMinimum=1, powerInput=True)
    with pytest.raises(FMUError, match="'fastest' is not one of"):
        sim.create(1, "Hub", dispatch="fastest")
    got = {"Hub_0": [], "Hub_1": []}
    for k in range(301):
        sim.step(k, {e: {"powerReference": {"w": wind[k]}} for e in got}, 10**6)
        for e, data in sim.get_data({e: HUB_OUTPUTS + ["operatingState"] for e in got}).items():
            got[e].append(list(data.values()))
    sim.finalize()
    ref = alone(
        fmu_path,
        wind[:300],
        outputs=HUB_OUTPUTS + ["operatingState"],
        nModules=N,
        dispatch=2,
        belowMinimum=1,
        powerInput=True,
    )
    for e, rows in got.items():
        assert np.array_equal(np.array(rows, dtype=float), np.column_stack(list(ref.values()))), e
    assert ref["modulesStandby"].max() > 0  # the sequential hub did use standby


def test_the_command_reports_on_stdout_only_and_ends_quietly_on_a_closed_one(tmp_path, fmu_path):
    args = [*SCENARIO, "--fmu", fmu_path, "--duration", 20, "--dispatch", "sequential", "--out", tmp_path / "c"]
    done = subprocess.run([sys.executable, *map(str, args)], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 3 and "sequential" in lines[0] and lines[2].startswith("wrote"), done.stdout
    assert_quiet(run_command(args))
    assert all((tmp_path / "c" / f"mosaik_cigre{s}").stat().st_size > 0 for s in (".csv", ".png"))
    assert_quiet(run_command([*SCENARIO, "--help"], buffered=True))
    blocked = tmp_path / "c" / "mosaik_cigre.csv" / "sub"
    done = run_command([*SCENARIO, "--fmu", fmu_path, "--out", blocked], stdout_closed=False, timeout=30)
    assert done.returncode == 1 and done.stderr.strip().splitlines() == [done.stderr.strip()], done.stderr
    assert "cannot write" in done.stderr and str(blocked) in done.stderr
