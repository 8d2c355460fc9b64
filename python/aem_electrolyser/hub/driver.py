"""The electrolyser hub FMU driven step by step through fmpy's FMU2Slave (the examples, the
mosaik and HELICS tests).

    hub = HubFMU(nModules=25000, dispatch=1, belowMinimum=0, powerInput=True)
    hub.initialize(powerReference=45e6)       # the hub starts in steady state for this input
    hub.step(1.0, powerReference=46e6)        # hold the reference over [t, t + 1 s]
    hub.get("hubPower", "hubEnergy")

A call the FMU refuses raises hub.messages.FmuError with the FMU's own message (its log is kept
in hub.messages.MESSAGES, not printed). Parameters and inputs are set by name with the setter of their FMI type (Real, Integer or
Enumeration, Boolean), so the FMU's variable names are the only interface; an enumeration takes
its code or the name of one of its items in the model description (dispatch="sequential"), as
study files do.
"""

import shutil
import weakref

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

from aem_electrolyser.cli import did_you_mean
from aem_electrolyser.hub.messages import fmu_words, instantiate
from aem_electrolyser.locate import fmu_path as locate_fmu


class HubFMU:
    def __init__(self, fmu_path=None, instance_name="hub", start_time=0.0, **parameters):
        fmu_path = locate_fmu(fmu_path)
        md = read_model_description(str(fmu_path))
        self._vars = {v.name: v for v in md.modelVariables}
        missing = [n for n in ("nModules", "powerReference", "hubPower") if n not in self._vars]
        if missing:
            raise ValueError(f"{fmu_path} has no hub variables {missing}: an older FMU?")
        self._unzipdir = extract(str(fmu_path))
        # Removed by close(), or when the object is collected or the interpreter exits.
        self._remove_unzipdir = weakref.finalize(self, shutil.rmtree, self._unzipdir, ignore_errors=True)
        self.fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self._unzipdir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        instantiate(self.fmu)
        self.fmu.setupExperiment(startTime=start_time)
        self.time = start_time
        self.initialized = False
        self.set(**parameters)

    def set(self, **values):
        with fmu_words(f"the values {values}"):
            self._set(values)

    def _set(self, values):
        for name, value in values.items():
            v = self._vars[name]
            if v.type == "Real":
                self.fmu.setReal([v.valueReference], [float(value)])
            elif v.type == "Enumeration":
                self.fmu.setInteger([v.valueReference], [self._code(v, value)])
            elif v.type == "Integer":
                self.fmu.setInteger([v.valueReference], [int(value)])
            elif v.type == "Boolean":
                self.fmu.setBoolean([v.valueReference], [bool(value)])
            else:
                raise TypeError(f"{name}: unsupported type {v.type}")

    @staticmethod
    def _code(variable, value):
        """The code of an enumeration's value: the name of one of its items (as the model
        description declares them) or a code (the FMU checks it)."""
        if not isinstance(value, str):
            return int(value)
        items = {item.name: int(item.value) for item in variable.declaredType.items}
        if value not in items:
            raise ValueError(
                f"{variable.name} = {value!r}: not one of {', '.join(items)} (or their codes "
                f"{', '.join(map(str, items.values()))}){did_you_mean(value, items)}"
            )
        return items[value]

    def get(self, *names):
        out = []
        for name in names:
            v = self._vars[name]
            getter = {
                "Real": self.fmu.getReal,
                "Integer": self.fmu.getInteger,
                "Enumeration": self.fmu.getInteger,
                "Boolean": self.fmu.getBoolean,
            }[v.type]
            out.append(getter([v.valueReference])[0])
        return out[0] if len(names) == 1 else out

    def initialize(self, **inputs):
        """Set the inputs at the start time; the FMU starts in steady state for them."""
        self.set(**inputs)
        with fmu_words("the initialisation"):
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
        self.initialized = True

    def step(self, h, **inputs):
        """Set the inputs (held over the step), then advance the FMU by h seconds."""
        self.set(**inputs)
        with fmu_words(f"the step at t = {self.time:g} s"):
            self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time += h

    def close(self):
        if self.initialized:
            try:
                self.fmu.terminate()
            except FMICallException:
                pass  # an instance in error ends with freeInstance alone; its refusal was raised
        self.fmu.freeInstance()
        self._remove_unzipdir()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
