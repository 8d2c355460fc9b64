"""The HELICS federation of aem_electrolyser.helics: a broker and the wind, hub and grid federates as
separate processes over zmq on 127.0.0.1, each test with its own ports and broker key.

* Ten simulated minutes (the 25 000-module hub, 1 s steps) run through the command
  `python -m aem_electrolyser.helics.run` (helics-cli on a runner file made from the packaged
  one), in bounded time, and every value a federate received is one another published,
  at the time HELICS's rules give: a federate that does not wait for the others at a time (wind,
  hub) gets a value published at t at its next grant, t + 1 s; the grid, which waits
  (wait_for_current_time_update), gets it at t; the hub gets w(0) from the wind's
  initializing mode at t = 0.
* The hub's outputs are, bit for bit, those of the FMU driven alone through fmpy with the same
  reference held over the same steps; the grid's, those of load flows run here without HELICS.
* The command writes everything into its --out folder (runner file, records, logs, a summary
  that agrees with the records and with conservation, a figure) and nothing beside the packaged
  runner file or in its working folder; a bad argument, to it or to a federate, is one line
  naming the option (status 2); a federate that fails is one line naming it (status 1).
* A federate that raises, a federate or the broker killed with SIGKILL, a step that hangs, a
  federate that never comes and a wall-clock limit reached each end every other process within
  bounded time with a non-zero status and a message naming what happened.

Expected values come from the FMU alone, the wind series recomputed, the FMU's model description
read with ElementTree, pandapower run here and HELICS's exchange rules; none from the federates.
"""

import json
import os
import random
import shlex
import signal
import socket
import struct
import subprocess
import sys
import time
import uuid
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

import pandapower as pp
import pandapower.networks as pn

import aem_electrolyser.helics
from aem_electrolyser.helics.records import read
from aem_electrolyser.hub import HubFMU
from aem_electrolyser.wind.farm import farm_power

# HELICS federations (the co-simulation lane). They run beside other tests: every wait polls for
# its condition, and a federate stuck in its own step reports before the others' watchdogs probe.
pytestmark = pytest.mark.cosim

#: The runner file ships with the package, beside the federates.
PACKAGE = Path(aem_electrolyser.helics.__file__).parent
RUNNER_FILE = PACKAGE / "federation.json"

DURATION, SEED, N_MODULES = 600, 1, 25_000
FEDERATES = ("wind", "hub", "grid")
HUB_OUTPUTS = ["hubPower", "hubEnergy", "hubH2Produced", "hubH2MassFlow"]
STALL = 5  # s, --stall-timeout of the failure tests
BOUND = 30  # s within which every process must have ended after a failure
# s the processes may take to start (interpreters, pandapower, joining) on a loaded machine before
# anything can fail: each bound counts from a sign that the failure's moment has come
STARTUP = 120
LIMIT = "1800s"  # the runner file's --maxcosimduration


def free_ports(n=12):
    """A first port p with p .. p+n-1 free on 127.0.0.1 (the broker takes p and p+1, zmq cores p+5 on)."""
    for _ in range(200):
        p = random.randrange(20000, 40000)
        socks = []
        try:
            for q in range(p, p + n):
                s = socket.socket()
                socks.append(s)
                s.bind(("127.0.0.1", q))
            return p
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    pytest.fail("no free block of ports on 127.0.0.1")


def table(path):
    """{column header: array} of a record."""
    header, rows = read(path)
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    return {h: data[:, i] for i, h in enumerate(header)}


def commands(out, port, key, fmu, duration=DURATION, common=(), broker=(), **extra):
    """The broker's and the federates' command lines, as federation.json has them but with this
    test's port, key, horizon and output folder."""
    runner = json.loads(RUNNER_FILE.read_text())
    cmds = {}
    for f in runner["federates"]:
        args = shlex.split(f["exec"])
        args = [
            a.replace("23404", str(port))
            .replace("--duration=3600", f"--duration={duration}")
            .replace(f"--maxcosimduration={LIMIT}", "--maxcosimduration=300s")
            for a in args
        ]
        args += [f"--brokerkey={key}"]
        if f["name"] == "broker":
            args += ["--wall-limit=330", *broker]
        else:  # a test that fails leaves nothing running for long
            args += [f"--out={out}", "--wall-limit=300", *common, *extra.get(f["name"], ())]
            if f["name"] == "hub":
                args += [f"--fmu={fmu}"]
        assert args[0] == "python"
        cmds[f["name"]] = [sys.executable, *args[1:]]
    return cmds


class Federation:
    """The processes of one federation, started directly (not through the runner), stdout and
    stderr in files; every wait is bounded and whatever is left is killed at the end."""

    def __init__(self, tmp, fmu, names=("broker", *FEDERATES), programs=None, **kw):
        self.tmp, self.out = tmp, tmp / "out"
        self.cmds = commands(self.out, free_ports(), f"test-{uuid.uuid4().hex}", fmu, **kw)
        for name, program in (programs or {}).items():
            self.cmds[name][1:3] = [str(program)]  # in place of -m aem_electrolyser.helics.NAME
        self.procs = {}
        for name in names:
            with open(tmp / f"{name}.out", "w") as o, open(tmp / f"{name}.err", "w") as e:
                self.procs[name] = subprocess.Popen(self.cmds[name], cwd=tmp, stdout=o, stderr=e)

    def wait_for_rows(self, record, rows, timeout=STARTUP):
        path, end = self.out / record, time.monotonic() + timeout
        while time.monotonic() < end:
            if path.exists() and len(path.read_text().splitlines()) > rows:
                return
            time.sleep(0.02)
        pytest.fail(f"{record} has not {rows} rows after {timeout} s")

    def wait(self, timeout):
        """{name: exit status}, all processes ended within timeout [s] or the test fails."""
        end = time.monotonic() + timeout
        status = {}
        for name, p in self.procs.items():
            try:
                status[name] = p.wait(timeout=max(0.1, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
        hung = [n for n in self.procs if n not in status]
        assert not hung, f"{hung} still running {timeout} s later; their stderr:\n" + "\n".join(
            f"--- {n}:\n{self.stderr(n)[-2000:]}" for n in hung
        )
        return status

    def stderr(self, name):
        return (self.tmp / f"{name}.err").read_text()

    def last_line(self, name):
        return self.stderr(name).strip().splitlines()[-1]

    def close(self):
        for p in self.procs.values():
            if p.poll() is None:
                p.kill()
                p.wait(timeout=10)


@pytest.fixture
def federation(tmp_path, fmu_path):
    made = []

    def start(**kw):
        f = Federation(tmp_path, fmu_path, **kw)
        made.append(f)
        return f

    yield start
    for f in made:
        f.close()


# --- the command: `python -m aem_electrolyser.helics.run` ----------------------------------------


def run_command(args, cwd, timeout=300):
    """Runs the command (its own process group, killed if it outlives timeout [s]); (status,
    stdout, stderr, wall [s])."""
    start = time.monotonic()
    p = subprocess.Popen(
        [sys.executable, "-m", "aem_electrolyser.helics.run", *map(str, args)],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        stdout, stderr = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        stdout, stderr = p.communicate()
        pytest.fail(f"the command still ran after {timeout} s:\n{stdout}\n{stderr}")
    return p.returncode, stdout, stderr, time.monotonic() - start


def package_listing():
    """The files beside the packaged runner file (Python's own __pycache__ left out)."""
    return sorted(p.name for p in PACKAGE.iterdir() if p.name != "__pycache__")


@pytest.fixture(scope="module")
def ten_minutes(fmu_path, tmp_path_factory):
    """Runs the command for DURATION s with this test's port and folders; (records, logs, wall [s])."""
    tmp = tmp_path_factory.mktemp("helics")
    out = tmp / "out"
    status, stdout, stderr, wall = run_command(
        [
            "--duration",
            DURATION,
            "--out",
            out,
            "--port",
            free_ports(),
            "--fmu",
            fmu_path,
            "--wall-limit",
            300,
            "--quiet",
        ],
        cwd=tmp,
    )
    logs = {
        name: (out / f"{name}.log").read_text() for name in ("broker", *FEDERATES) if (out / f"{name}.log").exists()
    }
    assert status == 0, stdout + stderr + "\n".join(logs.values())
    assert stdout == "" and stderr == ""  # --quiet
    records = {f"{n}_{kind}": table(out / f"{n}_{kind}.csv") for n in FEDERATES for kind in ("published", "received")}
    return records, logs, wall


def test_ten_minutes_run_in_bounded_time(ten_minutes):
    records, logs, wall = ten_minutes
    assert wall < 120, wall  # about 16 s on two cores with nothing else running
    assert "the federation ended normally" in logs["broker"]
    for name in FEDERATES:
        assert f"{name}: {DURATION} s simulated in" in logs[name]
        assert "error" not in logs[name].lower(), logs[name]
    for name, r in records.items():
        assert np.array_equal(r["time [s]"], np.arange(DURATION + 1.0)), name
        assert all(h.endswith(("[s]", "[W]", "[J]", "[kg]", "[kg/h]", "[pu]")) for h in r), list(r)


def test_every_value_received_was_published_at_the_time_helics_gives(ten_minutes):
    r = ten_minutes[0]
    wind = r["wind_published"]["wind/power [W]"]
    hub = r["hub_published"]["hub/hubPower [W]"]
    voltage = r["grid_published"]["grid/voltage [pu]"]
    # the grid waits for the others at every t: it gets what they published at t
    assert np.array_equal(r["grid_received"]["wind/power [W]"], wind)
    assert np.array_equal(r["grid_received"]["hub/hubPower [W]"], hub)
    # the hub gets w(0) from the wind's initializing mode at 0, then w(t - 1) at t
    assert np.array_equal(r["hub_received"]["wind/power [W]"], np.r_[wind[0], wind[:-1]])
    # wind and hub get the voltage the grid published at t - 1; nothing at 0
    for name in ("hub", "wind"):
        got = r[f"{name}_received"]["grid/voltage [pu]"]
        assert np.isnan(got[0]) and np.array_equal(got[1:], voltage[:-1]), name


def test_the_wind_is_the_seeded_series(ten_minutes):
    expected = farm_power(DURATION + 1.0, 1.0, seed=SEED)[1]
    assert np.array_equal(ten_minutes[0]["wind_published"]["wind/power [W]"], expected)


def kg_per_nl(fmu):
    """The factor of the display unit kg of the FMU's unit Nl, read with ElementTree."""
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    unit = next(u for u in root.iter("Unit") if u.get("name") == "Nl")
    return float(next(d for d in unit.iter("DisplayUnit") if d.get("name") == "kg").get("factor"))


def test_the_hub_is_the_fmu_driven_alone(ten_minutes, fmu_path):
    wind = farm_power(DURATION + 1.0, 1.0, seed=SEED)[1]
    with HubFMU(fmu_path, nModules=N_MODULES, dispatch=1, belowMinimum=0, powerInput=True) as hub:
        hub.initialize(powerReference=wind[0])
        rows = []
        for k in range(DURATION + 1):
            rows.append(hub.get(*HUB_OUTPUTS))
            if k < DURATION:
                hub.step(1.0, powerReference=wind[k])
    alone = dict(zip(HUB_OUTPUTS, np.array(rows).T))
    got = ten_minutes[0]["hub_published"]
    assert np.array_equal(got["hub/hubPower [W]"], alone["hubPower"])
    assert np.array_equal(got["hub/hubEnergy [J]"], alone["hubEnergy"])
    assert np.array_equal(got["hub/hubH2MassFlow [kg/h]"], alone["hubH2MassFlow"])
    assert np.array_equal(got["hub/hubH2Produced [kg]"], alone["hubH2Produced"] * kg_per_nl(fmu_path))
    assert 0.5 < alone["hubPower"].mean() / wind.mean() < 1.5  # it does follow the wind


def test_the_grid_gives_what_fresh_load_flows_give(ten_minutes):
    r = ten_minutes[0]
    received, published = r["grid_received"], r["grid_published"]
    net = pn.create_cigre_network_hv()
    bus = int(net.bus.index[net.bus.name == "Bus 1"][0])
    wind, hub = pp.create_sgen(net, bus, p_mw=0.0), pp.create_load(net, bus, p_mw=0.0)
    pp.runpp(net, numba=False)
    base = net.res_ext_grid.p_mw.sum() * 1e6
    for t in (0, 1, 2, 137, 300, 599, 600):
        net.sgen.at[wind, "p_mw"] = received["wind/power [W]"][t] / 1e6
        net.load.at[hub, "p_mw"] = received["hub/hubPower [W]"][t] / 1e6
        pp.runpp(net, numba=False)  # from pandapower's default start, matrices built anew
        # both converge to 1e-8 MVA, the federate from the previous solution: the same to rounding
        assert published["grid/voltage [pu]"][t] == pytest.approx(net.res_bus.at[bus, "vm_pu"], abs=1e-10)
        assert published["grid/slackPower [W]"][t] == pytest.approx(net.res_ext_grid.p_mw.sum() * 1e6, abs=0.1)
    # conservation: the slack takes the hub's load less the wind; the losses change by less than
    # 0.1 % of that (Bus 1 is next to the slack's transformer)
    net_load = received["hub/hubPower [W]"] - received["wind/power [W]"]
    assert np.all(np.abs(published["grid/slackPower [W]"] - base - net_load) <= 1e-3 * np.abs(net_load) + 1.0)
    assert np.abs(net_load).max() > 1e6  # the hub does not absorb the wind exactly


# --- the command's folder, summary and figure; its refusals ------------------------------------

#: What a run leaves in its folder, and nothing else.
RESULT_FILES = {
    "federation.json",
    "runner.log",
    "summary.json",
    "helics.png",
    *(f"{n}.log" for n in ("broker", *FEDERATES)),
    *(f"{n}_{kind}.csv" for n in FEDERATES for kind in ("published", "received")),
}
#: Faraday's law at the reversible cell voltage: no electrolyser makes a kg of hydrogen with less
#: than 2 F E_rev / M(H2) of electric energy [kWh/kg] (32.7 kWh/kg).
FARADAY_FLOOR = 2 * 96485.33212 * 1.229 / 2.01588e-3 / 3.6e6


def test_the_command_writes_everything_into_its_folder(tmp_path, fmu_path):
    """60 s with a 20 000-module hub in sequential dispatch and wind seed 3: the runner file,
    records, logs, summary and figure land in --out, nothing in the working folder nor beside the
    packaged runner file; the summary agrees with the records and with conservation."""
    before = package_listing()
    out, cwd, port = tmp_path / "run", tmp_path / "cwd", free_ports()
    cwd.mkdir()
    duration, modules, seed = 60, 20_000, 3
    status, stdout, stderr, wall = run_command(
        [
            "--duration",
            duration,
            "--out",
            out,
            "--modules",
            modules,
            "--dispatch",
            "sequential",
            "--seed",
            seed,
            "--port",
            port,
            "--fmu",
            fmu_path,
            "--wall-limit",
            300,
        ],
        cwd=cwd,
    )
    assert status == 0, stdout + stderr
    assert stderr == ""  # no bar: stdout is not a terminal
    assert package_listing() == before
    assert list(cwd.iterdir()) == []
    assert {p.name for p in out.iterdir()} == RESULT_FILES

    # the runner file: the packaged one with this run's values, the folder as working folder and --out
    runner = json.loads((out / "federation.json").read_text())
    template = json.loads(RUNNER_FILE.read_text())
    assert [f["name"] for f in runner["federates"]] == [f["name"] for f in template["federates"]]
    assert all(f["directory"] == "." for f in runner["federates"])
    execs = {f["name"]: shlex.split(f["exec"]) for f in runner["federates"]}
    assert len({a for e in execs.values() for a in e if a.startswith("--brokerkey=")}) == 1
    assert f"--port={port}" in execs["broker"]
    for name in FEDERATES:
        assert {f"--duration={duration}", "--out=.", f"--brokerport={port}"} <= set(execs[name]), execs[name]
    assert {f"--n-modules={modules}", "--dispatch=sequential"} <= set(execs["hub"])
    assert f"--seed={seed}" in execs["wind"]
    assert f"hub: {duration} s simulated in" in (out / "hub.log").read_text()
    assert f"({modules} modules, sequential dispatch)" in (out / "hub.log").read_text()

    r = {f"{n}_{kind}": table(out / f"{n}_{kind}.csv") for n in FEDERATES for kind in ("published", "received")}
    for name, record in r.items():
        assert np.array_equal(record["time [s]"], np.arange(duration + 1.0)), name
    hub = r["hub_published"]
    power, energy = hub["hub/hubPower [W]"], hub["hub/hubEnergy [J]"]
    h2, flow = hub["hub/hubH2Produced [kg]"], hub["hub/hubH2MassFlow [kg/h]"]
    wind = farm_power(duration + 1.0, 1.0, seed=seed)[1]  # the series recomputed here
    s = json.loads((out / "summary.json").read_text())
    assert (s["simulated duration [s]"], s["modules"], s["dispatch"], s["seed"]) == (
        duration,
        modules,
        "sequential",
        seed,
    )
    assert 0 < s["wall time [s]"] < wall
    # the FMU's own integrals at the end, and the wind the hub was given (w(t) held over [t, t + 1 s])
    assert s["hub energy [MWh]"] == pytest.approx((energy[-1] - energy[0]) / 3.6e9, rel=1e-12)
    assert s["hydrogen [kg]"] == pytest.approx(h2[-1] - h2[0], rel=1e-12)
    assert s["wind energy [MWh]"] == pytest.approx(wind[:-1].sum() / 3.6e9, rel=1e-12)
    # conservation: energy = integral of the power, hydrogen = integral of its mass flow
    # (trapezoids over the 1 s samples; the FMU integrates within its steps)
    assert s["hub energy [MWh]"] == pytest.approx(np.trapezoid(power) / 3.6e9, rel=5e-3)
    assert s["hydrogen [kg]"] == pytest.approx(np.trapezoid(flow) / 3600.0, rel=5e-3)
    assert s["specific energy [kWh/kg]"] == pytest.approx(1e3 * s["hub energy [MWh]"] / s["hydrogen [kg]"])
    assert FARADAY_FLOOR < s["specific energy [kWh/kg]"] < 2.5 * FARADAY_FLOOR
    # at the bus, what the hub does not take of the wind goes into the grid, and the reverse
    assert s["surplus into the grid [MWh]"] - s["drawn from the grid [MWh]"] == pytest.approx(
        s["wind energy [MWh]"] - s["hub energy [MWh]"], abs=1e-9
    )
    assert min(s["surplus into the grid [MWh]"], s["drawn from the grid [MWh]"]) >= 0
    assert s["hub power range [MW]"] == pytest.approx([power.min() / 1e6, power.max() / 1e6])
    slack, voltage = r["grid_published"]["grid/slackPower [W]"], r["grid_published"]["grid/voltage [pu]"]
    assert s["slack power range [MW]"] == pytest.approx([slack.min() / 1e6, slack.max() / 1e6])
    assert s["bus voltage range [pu]"] == pytest.approx([voltage.min(), voltage.max()])

    # the report on stdout says the same, with units
    assert stdout.startswith(f"HELICS federation: {duration} s simulated, broker at 127.0.0.1:{port}")
    for figure in (
        f"{s['wind energy [MWh]']:.3f} MWh",
        f"{s['hub energy [MWh]']:.3f} MWh",
        f"{s['hydrogen [kg]']:.2f} kg",
        f"{s['specific energy [kWh/kg]']:.1f} kWh/kg",
    ):
        assert figure in stdout, (figure, stdout)
    png = (out / "helics.png").read_bytes()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    width, height = struct.unpack(">II", png[16:24])
    assert width >= 600 and height >= 600, (width, height)


def test_a_failed_federation_is_one_line_naming_the_federate(tmp_path, fmu_path):
    out = tmp_path / "run"
    status, stdout, stderr, _ = run_command(
        [
            "--duration",
            60,
            "--fail-at",
            5,
            "--stall-timeout",
            STALL,
            "--out",
            out,
            "--port",
            free_ports(),
            "--fmu",
            fmu_path,
            "--wall-limit",
            300,
            "--quiet",
        ],
        cwd=tmp_path,
    )
    assert status == 1
    assert stderr.splitlines() == [
        "python -m aem_electrolyser.helics.run: error: the federation failed: grid exited with status 1: failed "
        f"at t=5 s: RuntimeError: simulated failure at t=5 s (--fail-at) (logs in {out.resolve()})"
    ], stderr
    assert stdout == ""
    assert not (out / "summary.json").exists() and not (out / "helics.png").exists()


@pytest.mark.parametrize(
    "program, args, expected",
    [
        ("run", ["--duration", "0"], "argument --duration: must be a positive integer, not 0"),
        (
            "run",
            ["--dispatch", "eqaul"],
            "argument --dispatch: 'eqaul' is not one of equal, sequential (did you mean 'equal'?)",
        ),
        ("run", ["--port", "80"], "argument --port: must be within 1024 to"),
        ("run", ["--duraton", "60"], "unknown option --duraton (did you mean '--duration'?)"),
        ("hub_federate", ["--dispatch", "eqaul"], "argument --dispatch: 'eqaul' is not one of equal, sequential"),
        ("wind_federate", ["--duration", "0"], "argument --duration: must be a positive integer, not 0"),
        ("wind_federate", ["--brokrport=23404"], "unknown option --brokrport (did you mean '--brokerport'?)"),
        ("grid_federate", ["--bus", "Bus 77"], "argument --bus: 'Bus 77' is not a bus of the CIGRE HV grid"),
    ],
)
def test_a_bad_argument_is_one_line_naming_it(program, args, expected, tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", f"aem_electrolyser.helics.{program}", *args, "--out", str(tmp_path / "out")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith(f"python -m aem_electrolyser.helics.{program}: error: {expected}"), done.stderr
    assert done.stdout == ""
    assert list(tmp_path.iterdir()) == []  # refused before anything was made


# --- failures ----------------------------------------------------------------------------------


def test_a_federate_that_raises_ends_the_federation(federation):
    f = federation(common=[f"--stall-timeout={STALL}"], grid=["--fail-at=30"])
    f.wait_for_rows("grid_published.csv", 29, timeout=STARTUP)  # it has finished t = 28 s
    status = f.wait(BOUND)
    assert all(s == 1 for s in status.values()), status
    assert f.last_line("grid") == "grid: failed at t=30 s: RuntimeError: simulated failure at t=30 s (--fail-at)"
    cause = "grid failed at t=30 s: RuntimeError: simulated failure at t=30 s (--fail-at)"
    for name in ("wind", "hub"):
        assert f.last_line(name).startswith(f"{name}: stopped at t="), f.last_line(name)
        assert f.last_line(name).endswith(cause)
    assert f.last_line("broker") == f"broker: the federation ended with an error: {cause}"
    assert table(f.out / "grid_published.csv")["time [s]"].max() == 29  # its step at 30 did not finish
    for name in ("wind", "hub"):  # nobody ran ahead of the grid by more than its inputs allow
        assert table(f.out / f"{name}_published.csv")["time [s]"].max() <= 31


@pytest.mark.parametrize("victim", ["grid", "hub", "broker"])
def test_a_killed_process_ends_the_federation(federation, victim):
    f = federation(common=[f"--stall-timeout={STALL}"])
    f.wait_for_rows("grid_received.csv", 30)
    killed = time.monotonic()
    f.procs[victim].send_signal(signal.SIGKILL)
    status = f.wait(BOUND)
    assert time.monotonic() - killed < BOUND
    assert status.pop(victim) == -signal.SIGKILL
    assert all(s == 1 for s in status.values()), status
    named = "the broker does not answer" if victim == "broker" else victim
    for name in status:
        line = f.last_line(name)
        assert named in line and "died or lost its connection" in line, (name, line)
        if name != "broker":
            assert line.startswith(f"{name}: stopped at t="), line


HANGING_GRID = """import sys, time
sys.argv[0] = "grid_federate.py"
from aem_electrolyser.helics import grid_federate
from aem_electrolyser.cli import quiet_on_closed_stdout
solve, calls = grid_federate.solve, []

def hanging(net, first):
    calls.append(1)
    while len(calls) > 30:  # the load flow at t = 30 s never returns
        time.sleep(1)
    solve(net, first)

grid_federate.solve = hanging
quiet_on_closed_stdout(grid_federate.main)
"""


def test_a_step_that_hangs_ends_the_federation(federation, tmp_path):
    program = tmp_path / "hanging_grid.py"
    program.write_text(HANGING_GRID)
    f = federation(common=[f"--stall-timeout={STALL}"], programs={"grid": program})
    f.wait_for_rows("grid_published.csv", 29, timeout=STARTUP)  # it has finished t = 28 s
    status = f.wait(BOUND)
    # the grid's watchdog raises the global error, then ends its stuck process (status 3)
    assert status == {"broker": 1, "wind": 1, "hub": 1, "grid": 3}, status
    cause = f"grid: its step at t=30 s has not finished after {STALL} s (--stall-timeout)"
    assert f.last_line("grid") == "grid: watchdog: the federate did not end within 10 s of the error: exiting"
    for name in ("broker", "wind", "hub"):
        assert f.last_line(name).endswith(cause), f.last_line(name)
    assert "Traceback" not in f.stderr("wind") + f.stderr("hub")


def test_a_federate_that_never_comes_ends_the_federation(federation):
    f = federation(names=("broker", "wind", "hub"), common=["--join-timeout=5"])
    status = f.wait(STARTUP + BOUND)  # the join timeout counts from each federate's start
    assert status == {"broker": 1, "wind": 1, "hub": 1}, status
    for name in status:
        line = f.last_line(name)
        assert "the federation has not started after 5 s" in line, line
        # in the order they came; when both watchdogs fire at once, a federate's line carries the
        # other's error and then its own diagnosis, each naming who joined
        assert "joined: wind, hub" in line or "joined: hub, wind" in line, line


SLOW_GRID = """import sys, time
sys.argv[0] = "grid_federate.py"
from aem_electrolyser.helics import grid_federate
from aem_electrolyser.cli import quiet_on_closed_stdout
solve = grid_federate.solve

def slow(net, first):
    time.sleep(0.2)  # a slow load flow: the federation runs, its processes mostly wait
    solve(net, first)

grid_federate.solve = slow
quiet_on_closed_stdout(grid_federate.main)
"""


def test_the_wall_clock_limit_ends_the_federation(federation, tmp_path):
    """The hub's wall-clock limit, reached while the federation runs (an hour of simulated time
    at 0.2 s a load flow), ends every process within BOUND. The limit counts from the hub's own
    start: the test first sees every federate exchanging values, so that the limit does not fall
    while a slow starter is still joining (a federate that joins an ended federation waits for
    HELICS's connection timeout, which is not what is tested here); 30 s leave room for the
    others' start on a loaded machine. The grid's load flows sleep, so the 30 s the test waits
    leave the CPU to the other tests."""
    program = tmp_path / "slow_grid.py"
    program.write_text(SLOW_GRID)
    f = federation(duration=3600, hub=["--wall-limit=30"], programs={"grid": program})
    for record in ("wind_published.csv", "hub_published.csv", "grid_published.csv"):
        f.wait_for_rows(record, 2, timeout=30)
    status = f.wait(30 + BOUND)
    assert all(s == 1 for s in status.values()), status
    for name in status:
        assert "hub: wall-clock limit of 30 s reached" in f.last_line(name), f.last_line(name)


@pytest.mark.parametrize("name", FEDERATES)
def test_an_unwritable_output_folder_ends_a_federate_at_once(name, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    done = subprocess.run(
        [sys.executable, "-m", f"aem_electrolyser.helics.{name}_federate", f"--out={blocker / 'out'}"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        f"python -m aem_electrolyser.helics.{name}_federate: error: cannot write {blocker / 'out'}: Not a directory"
    ]
    assert done.stdout == ""
