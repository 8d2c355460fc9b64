"""DEVELOPMENT STAND-IN, not a model: the single-module FMU scaled by nModules, with the
HubFMU interface of examples/hub_fmu.py, for equal dispatch with belowMinimum = 0 only (an
equal hub of N identical modules is exactly N x one module). Used while the hub is not yet in
the FMU; delete once it is."""
import math
import shutil

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave


class ModuleScaledHubStandIn:
    def __init__(self, fmu_path, instance_name="standin", start_time=0.0, nModules=1, dispatch=1,
                 belowMinimum=0, powerInput=False, **ignored):
        assert dispatch == 1 and belowMinimum == 0 and powerInput, "stand-in: equal, stay at minimum, power input"
        md = read_model_description(str(fmu_path))
        self._vr = {v.name: v.valueReference for v in md.modelVariables}
        self._start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None}
        self._unzipdir = extract(str(fmu_path))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=self._unzipdir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance_name)
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=start_time)
        self.n = nModules
        self.time = start_time
        self.initialized = False

    def _setpoint(self, p_hub):
        p = p_hub / self.n
        v0, r, k = self._start["voltageIntercept"], self._start["ohmicResistance"], self._start["gain"]
        i = 2 * p / (v0 + math.sqrt(v0 * v0 + 4 * r * p))
        return i / k

    def set(self, powerReference=None, **ignored):
        if powerReference is not None:
            self.fmu.setReal([self._vr["setpoint"]], [self._setpoint(powerReference)])

    def get(self, *names):
        out = []
        for name in names:
            if name in ("hubPower", "hubEnergy", "hubH2Produced", "hubH2Flow"):
                base = {"hubPower": "power", "hubEnergy": "energy", "hubH2Produced": "h2Produced",
                        "hubH2Flow": "h2Flow"}[name]
                out.append(self.n * self.fmu.getReal([self._vr[base]])[0])
            elif name == "hubH2MassFlow":
                out.append(self.n * self.fmu.getReal([self._vr["h2Flow"]])[0] * 0.08988e-3)
            elif name in ("modulesRunning",):
                out.append(self.n)
            elif name.startswith("modules") or name == "starts":
                out.append(0)
            else:
                out.append(self.fmu.getReal([self._vr[name]])[0])
        return out[0] if len(names) == 1 else out

    def initialize(self, **inputs):
        self.set(**inputs)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.initialized = True

    def step(self, h, **inputs):
        self.set(**inputs)
        self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time += h

    def close(self):
        if self.initialized:
            self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self._unzipdir, ignore_errors=True)
