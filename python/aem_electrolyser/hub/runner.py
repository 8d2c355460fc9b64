"""Runs the packaged FMU through a test signal, fast: one instance per run, loaded and set up by
fmpy, and stepped through the signal in native code (aem_drive: three FMI calls per step, with
neither the interpreter around them nor Python's global lock held).

The hub draws `powerReference` (powerInput = true); the frequency f[k] (or a power reference
p[k]) is set at t[k] and held over [t[k], t[k+1]]; the trace holds the power on the side the
reference means (hubPower; with gridSideReference what the grid sees, hubAcPower: hubPower with
the supplies' losses and the auxiliaries) and reserveRequest at every t[k] (the state reached
with the inputs of the previous interval). The FMU's log
messages (the window's shortfalls, ramp-limited increases) are counted in `messages`, not
printed.
"""

import ctypes
import functools
import math
import multiprocessing.util
import os
import shutil
import threading
import weakref
from dataclasses import dataclass

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

from aem_electrolyser.hub.messages import MESSAGES, fmu_words, instantiate, refusal
from aem_electrolyser.locate import drive_library as locate_drive
from aem_electrolyser.locate import fmu_path as locate_fmu

__all__ = ["Hub", "HubRunner", "MESSAGES"]


@dataclass(frozen=True)
class Hub:
    """The hub under test: modules, dispatch (1 equal, 2 sequential, 4 target: the running
    modules nearest dispatch_target [%], the FMU's dispatchTargetSetpoint), belowMinimum (0 stay
    at the minimum, 1 standby), baseline as a fraction of rated power, the reserve control
    (compensation: the slow pole cancelled; or filter_zero > 0: the transfer function's zero
    moved there [s], the FMU's reserveFilterZero), further FMU parameters set by name
    ((name, value) pairs: the grid side, the stack temperature), and how many of the modules
    not running wait in warm standby at the start (initialStandby; the others are idle)."""

    n_modules: int = 25_000
    dispatch: int = 1
    below_minimum: int = 0
    baseline: float = 0.8
    compensation: bool = False
    settings: tuple = ()
    filter_zero: float = 0.0
    dispatch_target: float = 80.0
    initial_standby: int = 0

    def control(self) -> str:
        """The reserve control in words."""
        if self.filter_zero > 0:
            return f"zero at {self.filter_zero:.4g} s"
        return "compensation on" if self.compensation else "compensation off"

    def describe(self) -> str:
        policy = {1: "equal", 2: "sequential", 3: "rotation", 4: f"target {self.dispatch_target:.4g} %"}[self.dispatch]
        settings = "".join(f", {name} = {value}" for name, value in self.settings)
        if self.initial_standby:
            settings += f", {self.initial_standby} in warm standby"
        return (
            f"{self.n_modules} modules, {policy} dispatch, baseline {100 * self.baseline:.0f} % of rated power, "
            f"{self.control()}{settings}"
        )


class HubRunner:
    """The packaged FMU, extracted once; `run` makes a fresh instance per call."""

    def __init__(self, fmu_path=None, hub=Hub()):
        self.fmu_path, self.hub = locate_fmu(fmu_path), hub
        self.md, self.unzipdir = _unpacked(self.fmu_path)
        self.vars = {v.name: v for v in self.md.modelVariables}
        # The FMU's library as fmpy loads it, once per thread that runs (a fresh instance each
        # run); unloaded by close(), or when the runner is collected or the interpreter exits.
        self._slaves, self._loaded = threading.local(), []
        self._release = weakref.finalize(self, _release, self._loaded)
        value = dict(hub.settings)
        names = ("gain", "voltageIntercept", "ohmicResistance", "maxSetpoint", "minSetpoint", "standbyPower")
        losses = ("supplyNoLoadLoss", "supplyLossVoltage", "supplyLossResistance", "auxiliaryPower")
        start = {name: float(value.get(name, self.vars[name].start)) for name in names + losses}
        grid_side = str(value.get("gridSideReference", self.vars["gridSideReference"].start)).lower() == "true"
        #: The output assessed: the power on the side the reference means.
        self.measured = "hubAcPower" if grid_side else "hubPower"

        def module_power(u):
            """A running module's steady power at u [%] as the power reference means it (the
            stack's, or with gridSideReference the grid's) [W]."""
            i = start["gain"] * u
            stack = (start["voltageIntercept"] + start["ohmicResistance"] * i) * i
            if not grid_side:
                return stack
            loss = start["supplyNoLoadLoss"] + (start["supplyLossVoltage"] + start["supplyLossResistance"] * i) * i
            return stack + loss + start["auxiliaryPower"]

        #: Rated power of the hub [W]: every module at maxSetpoint.
        self.rated_power = hub.n_modules * module_power(start["maxSetpoint"])
        #: The least steady power [W]: every module at minSetpoint if they never stop, else
        #: every module in standby.
        least = module_power(start["minSetpoint"]) if hub.below_minimum == 0 else start["standbyPower"]
        self.least_power = hub.n_modules * least
        #: Baseline consumption [W]: the power reference at rest.
        self.baseline = hub.baseline * self.rated_power
        #: The power drawn at rest [W], from which the tests measure: the baseline, and the
        #: standby power of the modules held warm (the FMU's own reading).
        self.resting_power = self.baseline
        if hub.initial_standby:
            self.resting_power = self.steady([self.measured])[self.measured]

    def close(self):
        self._release()

    def run(self, t, frequency=None, power_reference=None, parameters=None):
        """The power assessed (hubPower, or hubAcPower on the grid side) and reserveRequest [W]
        at every t[k] for the inputs held from t[k]."""
        t = np.ascontiguousarray(t, dtype=float)

        def steps(fmu):
            self._initialise(fmu, t[0], frequency, power_reference, parameters)
            return self._steps(fmu, t, frequency, power_reference)

        return self._with_instance(steps)

    def steady(self, names):
        """The outputs `names` (in their model-description units) of the hub at its baseline,
        where it starts in steady state (no frequency deviation, no reserve request)."""

        def read(fmu):
            self._initialise(fmu, 0.0, None, None, None)
            get = {"Real": fmu.getReal, "Integer": fmu.getInteger, "Enumeration": fmu.getInteger}
            return {n: get[self.vars[n].type]([self.vars[n].valueReference])[0] for n in names}

        return self._with_instance(read)

    def _slave(self):
        """This thread's fmpy FMU2Slave: the library loaded and its functions bound once."""
        fmu = getattr(self._slaves, "fmu", None)
        if fmu is None:
            fmu = FMU2Slave(
                guid=self.md.guid,
                unzipDirectory=self.unzipdir,
                modelIdentifier=self.md.coSimulation.modelIdentifier,
                instanceName="prequalification",
            )
            self._slaves.fmu = fmu
            self._loaded.append(fmu)
        return fmu

    def _with_instance(self, work):
        """`work(fmu)` on a fresh instance, freed afterwards (the library stays loaded for the
        next); the FMU's refusals in its words."""
        fmu = self._slave()
        instantiate(fmu)
        try:
            with fmu_words(f"the hub ({self.hub.describe()})"):
                return work(fmu)
        finally:
            try:
                fmu.terminate()
            except FMICallException:
                pass  # an instance in error ends with freeInstance alone; the first refusal was raised
            fmu.fmi2FreeInstance(fmu.component)
            fmu.component = None

    def _initialise(self, fmu, t0, frequency, power_reference, parameters):
        fmu.setupExperiment(startTime=float(t0))
        h = self.hub
        fmu.setInteger(
            [self.vars[n].valueReference for n in ("nModules", "dispatch", "belowMinimum")],
            [h.n_modules, h.dispatch, h.below_minimum],
        )
        if h.initial_standby:
            fmu.setInteger([self.vars["initialStandby"].valueReference], [h.initial_standby])
        fmu.setBoolean(
            [self.vars["powerInput"].valueReference, self.vars["reserveCompensation"].valueReference],
            [True, h.compensation],
        )
        for name, value in h.settings:
            v = self.vars[name]
            if v.type == "Real":
                fmu.setReal([v.valueReference], [float(value)])
            elif v.type in ("Integer", "Enumeration"):
                fmu.setInteger([v.valueReference], [int(value)])
            else:
                fmu.setBoolean([v.valueReference], [str(value).lower() == "true"])
        reals = dict(parameters or {})
        if h.filter_zero > 0:
            reals["reserveFilterZero"] = h.filter_zero
        if h.dispatch == 4:
            reals["dispatchTargetSetpoint"] = h.dispatch_target
        reals["powerReference"] = self.baseline if power_reference is None else float(power_reference[0])
        if frequency is not None:
            reals["frequency"] = float(frequency[0])
        names = list(reals)
        fmu.setReal([self.vars[n].valueReference for n in names], [float(reals[n]) for n in names])
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()

    def _steps(self, fmu, t, frequency, power_reference):
        n = len(t)
        driven = "frequency" if frequency is not None else "powerReference"
        values = np.ascontiguousarray(frequency if frequency is not None else power_reference, dtype=float)
        if values.shape != (n,):
            raise ValueError(f"{driven}: {values.size} values for {n} time points")
        outputs = np.empty((n, 2))
        output_vrs = (ctypes.c_uint * 2)(
            self.vars[self.measured].valueReference, self.vars["reserveRequest"].valueReference
        )
        failed_at = ctypes.c_size_t(n)
        # The loop in native code (aem_drive): per step the same three FMI calls, in the same
        # order, with the same arguments as a Python loop would make, without an interpreter's
        # microseconds around each.
        status = _drive()(
            ctypes.byref(_entries(fmu.dll)),
            fmu.component,
            n,
            _doubles(t),
            self.vars[driven].valueReference,
            _doubles(values),
            2,
            output_vrs,
            _doubles(outputs),
            ctypes.byref(failed_at),
        )
        if status > 1:  # fmi2Error or worse (warnings are logged, not fatal)
            k = failed_at.value
            raise refusal(f"the step at t = {t[k]} s (status {status})" if k < n else f"the steps (status {status})")
        power, request = outputs[:, 0].copy(), outputs[:, 1].copy()
        if not all(math.isfinite(x) for x in (power[-1], request[-1])):
            raise RuntimeError("the FMU returned a non-finite power")
        return power, request


def _release(loaded):
    """Unloads the FMU's library of every FMU2Slave in `loaded`."""
    while loaded:
        loaded.pop().freeLibrary()


#: The FMUs this process has unpacked: (model description, unzip directory) by (path,
#: modification time, size).
_UNPACKED: dict = {}
_UNPACKED_LOCK = threading.Lock()


def _forked():
    """In a forked child: the parent's unpacked FMUs are the parent's to remove (the child
    unpacks its own), and a lock another thread held at the fork would never be released."""
    global _UNPACKED_LOCK
    _UNPACKED.clear()
    _UNPACKED_LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forked)


def _unpacked(fmu_path):
    """(model description, unzip directory) of the .fmu at `fmu_path`, read and unpacked once per
    process (again if the file changes): a runner per job no longer pays for it (30-40 ms). The
    directory is removed when the process ends, by this process only: at the interpreter's exit,
    or a worker process's (multiprocessing's finalizers run there, where atexit does not)."""
    stat = os.stat(fmu_path)
    key = (os.path.realpath(fmu_path), stat.st_mtime_ns, stat.st_size)
    with _UNPACKED_LOCK:
        if key not in _UNPACKED:
            md = read_model_description(str(fmu_path))
            unzipdir = extract(str(fmu_path))
            multiprocessing.util.Finalize(None, shutil.rmtree, (unzipdir,), {"ignore_errors": True}, exitpriority=0)
            _UNPACKED[key] = (md, unzipdir)
        return _UNPACKED[key]


class _Entries(ctypes.Structure):
    """The FMU's entry points aem_drive calls (its `Entries`)."""

    _fields_ = [("set_real", ctypes.c_void_p), ("get_real", ctypes.c_void_p), ("do_step", ctypes.c_void_p)]


def _entries(dll):
    def address(name):
        return ctypes.cast(getattr(dll, name), ctypes.c_void_p).value

    return _Entries(address("fmi2SetReal"), address("fmi2GetReal"), address("fmi2DoStep"))


def _doubles(array):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


@functools.cache
def _drive():
    """aem_drive_series of this installation's stepping library (locate.drive_library)."""
    function = ctypes.CDLL(str(locate_drive())).aem_drive_series
    double = ctypes.POINTER(ctypes.c_double)
    function.argtypes = [
        ctypes.POINTER(_Entries),
        ctypes.c_void_p,
        ctypes.c_size_t,
        double,
        ctypes.c_uint,
        double,
        ctypes.c_size_t,
        ctypes.POINTER(ctypes.c_uint),
        double,
        ctypes.POINTER(ctypes.c_size_t),
    ]
    function.restype = ctypes.c_uint
    return function
