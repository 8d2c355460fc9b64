"""Shared fixtures: the packaged FMU, its model description, a driver with a captured logger,
and the paper's parameters with the closed-form responses the tests compare against."""

import itertools
import json
import math
import os
import shutil
from ctypes import byref
from pathlib import Path

import subprocess
from pathlib import PureWindowsPath

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

import aem_electrolyser

ROOT = Path(__file__).resolve().parents[2]
try:  # the installed package's FMU (the checkout's build, editable), or AEM_FMU
    FMU_PATH = aem_electrolyser.fmu_path()
except aem_electrolyser.NotBuilt as e:
    FMU_PATH, FMU_MISSING = None, str(e)

#: The paper's Table I and operating window, as the FMU names its parameters: one row (name,
#: value, unit, source) each. tests/data/table_i.json is the one copy the tests, fuzz/seeds.py
#: and benches/python_reference.py read; fmu/test_table_i.py checks that the FMU carries it.
TABLE_I_FILE = ROOT / "tests" / "data" / "table_i.json"
TABLE_I = json.loads(TABLE_I_FILE.read_text(encoding="utf-8"))
#: Table I by name: the FMU's parameter start values.
PAPER = {row["name"]: row["value"] for row in TABLE_I}

STATUS_LABELS = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"]

#: Live drivers by instance name. fmpy's native logger proxy (fmpy.logging.addLoggerProxy)
#: formats the variadic message and forwards it to ONE global Python callback, the last one
#: registered; this module's callback routes each message to its driver by instance name.
_DRIVERS = {}
_NAMES = itertools.count()


def _route(env, instance_name, status, category, message):
    d = _DRIVERS.get(instance_name.decode())
    if d is not None:
        d.messages.append((STATUS_LABELS[status], category.decode(), message.decode()))


_CALLBACKS = fmi2CallbackFunctions()
_LOGGER = fmi2CallbackLoggerTYPE(_route)
_CALLBACKS.logger = _LOGGER


@pytest.fixture(scope="session")
def fmu_path():
    if FMU_PATH is None:
        pytest.fail(FMU_MISSING)
    return FMU_PATH


@pytest.fixture(scope="session")
def unzipdir(fmu_path, tmp_path_factory):
    target = tmp_path_factory.mktemp("fmu")
    extract(str(fmu_path), str(target))
    yield str(target)
    shutil.rmtree(target, ignore_errors=True)


@pytest.fixture(scope="session")
def model_description(fmu_path):
    return read_model_description(str(fmu_path))


class Driver:
    """One FMU instance driven through fmpy's FMU2Slave, with its log captured.

    `messages` holds (status label, category, message) tuples from the FMU's logger.
    """

    def __init__(self, unzipdir, model_description, name=None, logging_on=False):
        self.md = model_description
        self.vr = {v.name: v.valueReference for v in model_description.modelVariables}
        self.messages = []
        name = name or f"aem{next(_NAMES)}"
        _DRIVERS[name] = self
        # (Re-)register the routing callback: another test may have registered its own.
        # addLoggerProxy swaps the struct's logger for the native proxy, so restore it first.
        _CALLBACKS.logger = _LOGGER
        addLoggerProxy(byref(_CALLBACKS))
        self._callbacks = _CALLBACKS
        self.fmu = FMU2Slave(
            guid=model_description.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=model_description.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.fmu.instantiate(callbacks=self._callbacks, loggingOn=logging_on)
        self.time = 0.0

    def initialize(self, setpoint=100.0, start_time=0.0, **parameters):
        """setupExperiment, parameters and setpoint, enter/exit initialization mode."""
        self.fmu.setupExperiment(startTime=start_time)
        self.set(setpoint=setpoint, **parameters)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.time = start_time
        return self

    def set(self, **values):
        names = list(values)
        self.fmu.setReal([self.vr[n] for n in names], [float(values[n]) for n in names])

    def get(self, *names):
        values = self.fmu.getReal([self.vr[n] for n in names])
        return values[0] if len(names) == 1 else values

    def step(self, h, setpoint=None):
        if setpoint is not None:
            self.set(setpoint=setpoint)
        self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time += h

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture
def driver(unzipdir, model_description):
    """Factory for drivers; every instance made is freed at the end of the test."""
    made = []

    def make(**kwargs):
        d = Driver(unzipdir, model_description, **kwargs)
        made.append(d)
        return d

    yield make
    for d in made:
        try:
            d.fmu.freeInstance()
        except Exception:
            pass


#: The model page's worked example of the grid side (docs/model.md): auxiliaries and supply losses.
WORKED_EXAMPLE = {
    "auxiliaryPower": 150.0,
    "supplyNoLoadLoss": 30.0,
    "supplyLossVoltage": 0.6,
    "supplyLossResistance": 0.015,
}


def module_power(setpoint, p=PAPER):
    """Steady stack power of one module [W] at `setpoint` [%]: (V0 + R*K*u)*K*u."""
    i = p["gain"] * setpoint
    return (p["voltageIntercept"] + p["ohmicResistance"] * i) * i


def setpoint_for(power, p=PAPER):
    """Setpoint [%] at which one module draws `power` [W] (the inverse polarisation curve)."""
    v0, r = p["voltageIntercept"], p["ohmicResistance"]
    return 2.0 * power / (p["gain"] * (v0 + math.sqrt(v0 * v0 + 4.0 * r * power)))


def modal_weights(p=PAPER):
    """G(s) = K(a/(tauPole1 s+1) + b/(tauPole2 s+1)) with a + b = 1."""
    a = (p["tauZero"] - p["tauPole1"]) / (p["tauPole2"] - p["tauPole1"])
    return a, 1.0 - a


def unlimited_step_response(u0, u1, t, p=PAPER):
    """Current [A] t seconds after a setpoint step u0 -> u1 [%] from steady state, no rate limit."""
    a, b = modal_weights(p)
    k = p["gain"]
    return k * u1 + k * (u0 - u1) * (a * math.exp(-t / p["tauPole1"]) + b * math.exp(-t / p["tauPole2"]))


WINE = Path("/usr/lib/wine/wine64")


def windows_path(path):
    """Wine's name for a path of this machine: / is drive Z:."""
    return str(PureWindowsPath("Z:/") / Path(path).resolve().relative_to("/"))


@pytest.fixture(scope="session")
def wine(tmp_path_factory):
    """Runs a Windows program under Wine in a throwaway prefix, with the test-only
    bcryptprimitives.dll on its search path; returns its stdout (CRLF as LF)."""
    gcc = shutil.which("x86_64-w64-mingw32-gcc")
    if not WINE.is_file() or gcc is None:
        pytest.fail("wine64 and mingw-w64 are not installed (scripts/setup.sh installs them)")
    base = tmp_path_factory.mktemp("wine")
    shim = base / "shim"
    shim.mkdir()
    subprocess.run(
        [
            gcc,
            "-O2",
            "-shared",
            "-o",
            str(shim / "bcryptprimitives.dll"),
            str(ROOT / "tests" / "windows" / "bcryptprimitives.c"),
            "-ladvapi32",
        ],
        check=True,
    )
    env = dict(os.environ, WINEPREFIX=str(base / "prefix"), WINEDEBUG="-all", WINEPATH=windows_path(shim))
    env.pop("DISPLAY", None)

    def run_windows(exe, *args, shim_on_path=True, check=True):
        cmd = [WINE, exe, *args]
        done = subprocess.run(
            [str(c) for c in cmd],
            capture_output=True,
            timeout=600,
            env=env if shim_on_path else {**env, "WINEPATH": ""},
        )
        out = done.stdout.decode(errors="replace").replace("\r\n", "\n")
        if check:
            assert done.returncode == 0, f"{cmd}\nexit {done.returncode}\n{out}\n{done.stderr.decode(errors='replace')}"
            return out
        return done

    return run_windows


#: The tests that rebuild the FMU's library in the checkout's target folder from another model
#: description (packaging/package.py --parameters) or package the library found there
#: (--no-build): on one worker, one after the other, or one would package what another is
#: overwriting (seen: validation_day refused a library rebuilt meanwhile for other parameters).
REBUILDS_THE_LIBRARY = pytest.mark.xdist_group("rebuilds-the-library")


def pytest_itemcollected(item):
    """Under pytest-xdist's loadgroup distribution (scripts/test.sh, scripts/check.sh), the tests
    that use a module-scoped fixture of their module (an hour of co-simulation, a built site, an
    installed wheel) go to one worker together, so the fixture is made once; every other test is
    given to whichever worker is free. (Marked as each test is collected: xdist reads the groups
    in its own pytest_collection_modifyitems.)"""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return
    shared = any(
        d.scope == "module" and d.baseid and item.nodeid.startswith(d.baseid)
        for defs in info.name2fixturedefs.values()
        for d in defs
    )
    if shared:
        item.add_marker(pytest.mark.xdist_group(item.path.stem))
