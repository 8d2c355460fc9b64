"""mosaik API v3 simulator for the AEM electrolyser FMU (FMI 2.0 Co-Simulation), on fmpy.

    SIM_CONFIG = {"AEM": {"python": "aem_electrolyser.mosaik.simulator:AemSimulator"}}
    aem = world.start("AEM", fmu=str(aem_electrolyser.fmu_path()), step_size=1.0)
    hub = aem.Hub(nModules=25000, dispatch=1, powerInput=True)        # dispatch="equal" if an Enumeration
    module = aem.Module(minSetpoint=60.0)                              # one module, setpoint mode

Models, derived from the FMU's model description:

* `Hub`: every FMU parameter is a model parameter (defaults: the FMU's start values); every
  input and output is an attribute.
* `Module`: one module driven by its `setpoint` [%] (nModules = 1, powerInput = false; the other
  hub-only parameters dispatch, hysteresis, parameterSpread and spreadSeed keep their start values).

Each model description also has `units` (attribute or parameter -> unit: the FMU's unit, or the
"[...]" at the end of its description, "1" for a count, flag or enumeration), `descriptions` and
`enumerations` (Enumeration variable -> {item name: value}; set a parameter by name or value).

Sim params: `fmu` (path), `step_size` [s] (a multiple of the world's `time_resolution` [s per mosaik
tick]; default the FMU's default experiment step), `logging_on` (the FMU's debug log).

Time convention (one FMU instance per entity, created in `create`, freed in `finalize`): at the
entity's first step, at mosaik time t0, the inputs received are set and the FMU is initialised
(it starts in steady state for them). At each later step t the FMU first advances from the
previous step t' to t with the inputs received at t' (held over [t', t), as
aem_electrolyser.hub.driver does), then takes the inputs received at t. `get_data` at t gives the FMU's
outputs at t. The powers have no direct feedthrough (only reserveRequest follows the frequency
at once), so a successor stepped at t (a grid) sees
the hub's power at t; the input of t acts from t on. An input given by several sources is their
sum if its unit is W, an error otherwise; an input given no value is held.

The FMU's log goes to loguru (stderr, as mosaik's own log), never to stdout. A call the FMU
refuses (fmi2Error) raises `FMUError` naming the entity, the FMI function and the FMU's message.
"""

import itertools
import math
import re
import shutil
from ctypes import byref

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

from aem_electrolyser.extras import needs

with needs("mosaik", __name__):
    import mosaik_api_v3
    from loguru import logger

HUB_ONLY = ("nModules", "dispatch", "powerInput", "hysteresis", "parameterSpread", "spreadSeed")
MODULE_FIXED = {"nModules": 1, "powerInput": False}
STATUS = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"]
LEVEL = {0: "INFO", 1: "WARNING", 2: "WARNING", 3: "ERROR", 4: "CRITICAL"}


class FMUError(RuntimeError):
    """An FMI call refused by the FMU; the message names the entity and gives the FMU's log."""


# fmpy formats the FMU's variadic log call in a native proxy that forwards it to one Python
# function per process, the last one registered: messages are routed by instance name.
_LIVE = {}


def _route(_env, instance_name, status, category, message):
    name, text = instance_name.decode(errors="replace"), message.decode(errors="replace")
    if name in _LIVE:
        _LIVE[name].messages.append((status, text))
        if status >= 2:  # a refusal: the FMUError it raises carries the text (one report, not two)
            logger.debug("FMU {} refused: {}", name, text)
            return
    logger.log(
        LEVEL.get(status, "ERROR"),
        "FMU {} [{}] {}: {}",
        name,
        STATUS[status] if status < 6 else status,
        category.decode(errors="replace"),
        text,
    )


_CALLBACKS = fmi2CallbackFunctions()
_LOGGER = fmi2CallbackLoggerTYPE(_route)
_CALLBACKS.allocateMemory = defaultCallbacks.allocateMemory
_CALLBACKS.freeMemory = defaultCallbacks.freeMemory


def _register_logger():
    """(Re-)makes _route the target of fmpy's proxy (another importer may have taken it)."""
    _CALLBACKS.logger = _LOGGER
    addLoggerProxy(byref(_CALLBACKS))


def unit_of(v):
    """Unit of a model variable: its unit, else the "[...]" closing its description, else "1"
    for Integer, Enumeration and Boolean, "" for String."""
    unit = v.unit or (v.declaredType.unit if v.declaredType is not None else None)
    if unit:
        return unit
    m = re.search(r"\[([^\]]+)\]\s*$", v.description or "")
    return m.group(1) if m else ("" if v.type == "String" else "1")


def _model(variables, params, attrs):
    names = params + attrs
    return {
        "public": True,
        "params": params,
        "attrs": attrs,
        "any_inputs": False,
        "units": {n: unit_of(variables[n]) for n in names},
        "descriptions": {n: variables[n].description or "" for n in names},
        "enumerations": {
            n: {i.name: int(i.value) for i in variables[n].declaredType.items}
            for n in names
            if variables[n].type == "Enumeration"
        },
    }


def make_meta(md):
    """mosaik meta of the models Hub and Module from an fmpy ModelDescription."""
    v = {x.name: x for x in md.modelVariables}
    params = [n for n, x in v.items() if x.causality == "parameter"]
    inputs = [n for n, x in v.items() if x.causality == "input"]
    outputs = [n for n, x in v.items() if x.causality == "output"]
    module_params = [n for n in params if n not in HUB_ONLY]
    return {
        "api_version": "3.0",
        "type": "time-based",
        "models": {
            "Hub": _model(v, params, inputs + outputs),
            "Module": _model(v, module_params, [n for n in inputs if n != "powerReference"] + outputs),
        },
    }


class _Instance:
    """One FMU instance: set/get by name, held inputs, log captured for errors."""

    def __init__(self, eid, model, name, md, unzipdir, variables, parameters, logging_on):
        self.eid, self.model, self.name, self.vars = eid, model, name, variables
        self.messages, self.time, self.initialized = [], None, False
        self.fmu = FMU2Slave(
            guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name
        )
        _register_logger()
        _LIVE[name] = self
        try:
            self.call("fmi2Instantiate", self.fmu.instantiate, callbacks=_CALLBACKS, loggingOn=logging_on)
        except FMUError:
            _LIVE.pop(name, None)
            self.fmu.freeLibrary()
            raise
        try:
            self.set(parameters)
        except Exception:
            self.free()
            raise

    def call(self, what, fn, *args, **kwargs):
        self.messages.clear()  # the FMU's messages during this call
        try:
            return fn(*args, **kwargs)
        except FMICallException as e:
            told = (
                "; ".join(text.removeprefix(f"{e.function}: ") for status, text in self.messages if status >= 2)
                or "no message from the FMU"
            )
            raise FMUError(
                f"{self.eid}: {e.function} failed ({STATUS[e.status] if e.status < 6 else e.status}): {told}"
            ) from None
        except Exception as e:  # instantiate failing, a wrong type
            told = "; ".join(text.removeprefix(f"{what}: ") for status, text in self.messages if status >= 2)
            raise FMUError(f"{self.eid}: {what}: {told or e}") from e

    def _value(self, name, value):
        v = self.vars[name]
        if v.type == "Enumeration" and isinstance(value, str):
            items = {i.name: int(i.value) for i in v.declaredType.items}
            if value not in items:
                raise FMUError(f"{self.eid}: {name} = {value!r} is not one of {sorted(items)}")
            return items[value]
        return value

    def set(self, values):
        setters = {
            "Real": (self.fmu.setReal, float),
            "Integer": (self.fmu.setInteger, int),
            "Enumeration": (self.fmu.setInteger, int),
            "Boolean": (self.fmu.setBoolean, bool),
            "String": (self.fmu.setString, str),
        }
        for name, value in values.items():
            setter, cast = setters[self.vars[name].type]
            self.call(f"set {name}", setter, [self.vars[name].valueReference], [cast(self._value(name, value))])

    def get(self, names):
        getters = {
            "Real": self.fmu.getReal,
            "Integer": self.fmu.getInteger,
            "Enumeration": self.fmu.getInteger,
            "Boolean": self.fmu.getBoolean,
            "String": self.fmu.getString,
        }
        out = {}
        for kind, getter in getters.items():
            group = [n for n in names if self.vars[n].type == kind]
            if group:
                values = self.call(f"get {group}", getter, [self.vars[n].valueReference for n in group])
                out.update(zip(group, (v.decode() if isinstance(v, bytes) else v for v in values)))
        return {n: out[n] for n in names}

    def advance(self, t, inputs):
        """Bring the FMU to time t [s] with the inputs held since the last call, then set `inputs`."""
        if not self.initialized:
            self.call("setupExperiment", self.fmu.setupExperiment, startTime=t)
            self.set(inputs)
            self.call("enterInitializationMode", self.fmu.enterInitializationMode)
            self.call("exitInitializationMode", self.fmu.exitInitializationMode)
            self.initialized, self.time = True, t
            return
        if t > self.time:
            self.call(
                "doStep", self.fmu.doStep, currentCommunicationPoint=self.time, communicationStepSize=t - self.time
            )
            self.time = t
        self.set(inputs)

    def free(self):
        _register_logger()
        try:
            if self.initialized:
                self.fmu.terminate()
        except FMICallException:
            pass  # an instance in error state: terminate is not allowed, free it anyway
        finally:
            self.fmu.freeInstance()
            _LIVE.pop(self.name, None)


class AemSimulator(mosaik_api_v3.Simulator):
    def __init__(self):
        super().__init__({"models": {}})
        self.entities, self._counters = {}, {}
        self._unzipdir = None

    def init(self, sid, time_resolution=1.0, fmu=None, step_size=None, logging_on=False):
        if fmu is None:
            raise ValueError("sim param fmu (path of AemElectrolyser.fmu) is missing")
        self.sid, self.resolution, self.logging_on = sid, float(time_resolution), bool(logging_on)
        self.md = read_model_description(str(fmu))
        self.vars = {v.name: v for v in self.md.modelVariables}
        if step_size is None:
            step_size = self.md.defaultExperiment.stepSize if self.md.defaultExperiment else 1.0
        ticks = float(step_size) / self.resolution
        if not (ticks >= 1 and math.isclose(ticks, round(ticks), rel_tol=0, abs_tol=1e-9)):
            raise ValueError(
                f"step_size {step_size} s is not a positive multiple of time_resolution {self.resolution} s"
            )
        self.step_ticks = round(ticks)
        self._unzipdir = extract(str(fmu))
        self.meta.update(make_meta(self.md))
        return self.meta

    def create(self, num, model, **params):
        desc = self.meta["models"].get(model)
        if desc is None:
            raise ValueError(f"unknown model {model!r}; models: {sorted(self.meta['models'])}")
        unknown = sorted(set(params) - set(desc["params"]))
        if unknown:
            raise ValueError(f"{model} has no parameters {unknown}; it has {desc['params']}")
        values = {**(MODULE_FIXED if model == "Module" else {}), **params}
        counter = self._counters.setdefault(model, itertools.count())
        created = []
        for _ in range(num):
            eid = f"{model}_{next(counter)}"
            self.entities[eid] = _Instance(
                eid, model, f"{self.sid}.{eid}", self.md, self._unzipdir, self.vars, values, self.logging_on
            )
            created.append({"eid": eid, "type": model})
        return created

    def _inputs(self, eid, attrs):
        desc = self.meta["models"][self.entities[eid].model]
        values = {}
        for attr, sources in attrs.items():
            if attr not in desc["attrs"] or self.vars[attr].causality != "input":
                raise ValueError(f"{eid}: {attr} is not an input of {self.entities[eid].model}")
            given = [x for x in sources.values() if x is not None]
            if len(given) > 1 and desc["units"][attr] != "W":
                raise ValueError(f"{eid}: {attr} [{desc['units'][attr]}] has several sources {sorted(sources)}")
            if given:
                values[attr] = math.fsum(given) if len(given) > 1 else given[0]
        return values

    def step(self, time, inputs, max_advance):
        _register_logger()
        t = time * self.resolution
        for eid, entity in self.entities.items():
            entity.advance(t, self._inputs(eid, inputs.get(eid, {})))
        return time + self.step_ticks

    def get_data(self, outputs):
        data = {}
        for eid, attrs in outputs.items():
            entity = self.entities[eid]
            unknown = set(attrs) - set(self.meta["models"][entity.model]["attrs"])
            if unknown:
                raise ValueError(f"{eid} has no attributes {sorted(unknown)}")
            data[eid] = entity.get(attrs)
        return data

    def finalize(self):
        for entity in self.entities.values():
            entity.free()
        self.entities.clear()
        if self._unzipdir:
            shutil.rmtree(self._unzipdir, ignore_errors=True)
            self._unzipdir = None
