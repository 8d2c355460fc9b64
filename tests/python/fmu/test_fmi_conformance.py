"""FMI 2.0 conformance of the packaged AemElectrolyser co-simulation FMU.

What is checked, against the FMI 2.0 standard (chapters 2 and 4) and this FMU's contract:

1. Packaging: validators, units, archive contents, the 34 exported functions, version inquiry,
   fmi2Instantiate refusing what it cannot serve.
2. FMU state: get/set and serialize/deserialize round trips continue bit for bit, also in
   another instance; corrupt serialised bytes are refused and change nothing.
3. Instances share no state.
4. fmi2Reset returns to the state after fmi2Instantiate.
5. Instantiate/free cycles neither leak memory nor drift.
6. Every refused call returns fmi2Error (or fmi2Discard), logs why, and changes nothing: the
   instance continues exactly like an undisturbed twin.
7. Debug-logging categories.
8. End to end with fmpy.simulate_fmu.
"""

import math
import os
import random
import struct
import subprocess
import sys
import re
import zipfile
import zlib
from ctypes import byref, c_char_p, c_double, c_int, c_uint, create_string_buffer
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
from fmpy import platform, sharedLibraryExtension, simulate_fmu
from fmpy.util import fmu_info
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2CoSimulation,
    fmi2DoStepStatus,
    fmi2FMUstate,
    fmi2LastSuccessfulTime,
    fmi2ModelExchange,
    fmi2PendingStatus,
    fmi2Terminated,
)
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu

from conftest import PAPER, ROOT, STATUS_LABELS, unlimited_step_response

# ---------------------------------------------------------------- constants

FMI_OK, FMI_WARNING, FMI_DISCARD, FMI_ERROR = 0, 1, 2, 3
CATEGORY_OF_STATUS = {FMI_WARNING: "logStatusWarning", FMI_DISCARD: "logStatusDiscard", FMI_ERROR: "logStatusError"}

VR_SETPOINT = 0
VR_CURRENT = 1
VR_GAIN = 100
OUTPUT_NAMES = ("current", "voltage", "power", "h2Flow", "energy", "h2Produced")
OUTPUT_VRS = (1, 2, 3, 4, 5, 6)
PARAMETER_NAMES = tuple(PAPER)
PARAMETER_VRS = tuple(range(100, 111))
UNKNOWN_VRS = (29, 99, 2**32 - 1)

#: Setpoint [%] at initialisation (inside the operating window [60, 100] %).
INITIAL_SETPOINT = 80.0

#: FMI 2.0 section 2.1: functions every FMU exports ...
FMI2_COMMON_FUNCTIONS = (
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
)
#: ... and (section 4.2) those of co-simulation.
FMI2_CS_FUNCTIONS = (
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
)

FMUTOOL = Path(sys.executable).with_name("fmutool")

# Serialised FMU state (src/fmi2/fmu_state.rs, format 11): magic(8) version(4) payload length(4)
# payload crc32(4); payload = GUID length(4) GUID, FMI state code, excursion and stop-time flags
# (1 each), 11 f64 parameters (gain first), 5 u32 and 1 u8 hub settings, 9 f64 hub settings,
# 7 f64, 1 u8 and 1 f64 reserve settings, the thermal model's u8 switch, u32 nCells and 10 f64, the grid
# side's u8 switch and 4 f64, the ageing's 6 f64, 7 f64 (setpoint, powerReference, frequency, ambientTemperature,
# setpoint slope, time, stop time), the module parameter file (u32 length, here 0, and its
# bytes), a flag and a u32 count of parameter sets (here none), the reserves' state (u8 FFR
# state, f64 its end, two u8 flags), plant kind (1), and for a single module 11 f64 (time, the
# three current states, energy, hydrogen, stack temperature, charge, integral of I^2, the
# irreversible and reversible drift).
STATE_MAGIC, STATE_VERSION, STATE_LENGTH, STATE_PAYLOAD = 0, 8, 12, 16
STATE_FLAGS = 3
STATE_AFTER_PARAMETERS = (
    8 * 11
    + 4 * 5
    + 1
    + 8 * 9
    + 8 * 7
    + 1
    + 8
    + (1 + 4 + 8 * 10)
    + (1 + 8 * 4)
    + 8 * 6
    + 8 * 7
    + 4
    + 1
    + 4
    + (1 + 8 + 1 + 1)
    + 1
    + 8 * 11
)

# Life-cycle test.
CYCLES = 1000
RSS_BASELINE_CYCLE = 100
MAX_RSS_GROWTH = 4 * 2**20  # bytes


def make_schedule(seed, n):
    """n steps of (step size [s], setpoint [%] or None to keep the last one): rate-limited
    rises, free falls, excursions outside the window, several step sizes."""
    rng = random.Random(seed)
    return [
        (rng.choice((0.1, 0.5, 1.0, 2.5, 10.0, 37.0)), rng.choice((None, None, 45.0, 60.0, 72.5, 88.0, 100.0, 115.0)))
        for _ in range(n)
    ]


PREFIX = make_schedule(1, 25)
CONTINUATION = [(1.0, None), (2.0, None), (0.5, None)] + make_schedule(2, 30)

# ---------------------------------------------------------------- helpers


def outputs(d):
    """All six outputs of a driver, in value-reference order."""
    return tuple(d.fmu.getReal(OUTPUT_VRS))


def run(d, schedule):
    """Steps through `schedule`; the outputs after each step."""
    rows = []
    for h, setpoint in schedule:
        d.step(h, setpoint=setpoint)
        rows.append(outputs(d))
    return rows


def _bits(row):
    return struct.pack(f"<{len(row)}d", *row)


def assert_bit_identical(actual, expected):
    """Rows of floats are equal bit for bit (not approximately)."""
    assert len(actual) == len(expected), f"{len(actual)} rows != {len(expected)} rows"
    for i, (a, e) in enumerate(zip(actual, expected)):
        assert _bits(a) == _bits(e), f"row {i} differs: {a!r} != {e!r}"


def snapshot(d):
    """The instance's complete state as serialised bytes."""
    state = d.fmu.getFMUstate()
    try:
        return d.fmu.serializeFMUstate(state)
    finally:
        d.fmu.freeFMUstate(state)


def status_of(action):
    """The fmi2Status of an fmpy call: OK/Warning if it returned, else the raised status."""
    try:
        action()
    except FMICallException as e:
        return e.status
    return FMI_OK


def call(d, function, *args):
    """fmi2<function>(component, *args) straight through ctypes; returns the fmi2Status."""
    return getattr(d.fmu.dll, function)(d.fmu.component, *args)


def uints(*values):
    return (c_uint * len(values))(*values)


def reals(*values):
    return (c_double * len(values))(*values)


def ints(*values):
    return (c_int * len(values))(*values)


def assert_logged(messages, status, *words):
    """A message of `status` in its logStatusX category mentions every word (any case)."""
    label, category = STATUS_LABELS[status], CATEGORY_OF_STATUS[status]
    candidates = [m for s, c, m in messages if s == label and c == category]
    assert candidates, f"no {label} message in category {category}; log: {messages}"
    assert any(all(w.lower() in m.lower() for w in words) for m in candidates), (
        f"no {label} message mentions all of {words}; got: {candidates}"
    )


def reseal(blob):
    """The serialised state with its CRC-32 recomputed, so the inner checks are reached."""
    return blob[:-4] + struct.pack("<I", zlib.crc32(blob[:-4]))


class PythonLogger:
    """fmi2CallbackFunctions whose logger calls sink(instance name, (status label, category, message)).

    fmpy's native logger proxy (fmpy.logging.addLoggerProxy) formats the message and keeps one
    global Python logger, the last one registered: with several conftest Drivers alive, every
    message lands in the last Driver's `messages`. Registering one of these after the drivers,
    routing by instance name (see named_drivers), restores the attribution."""

    def __init__(self, sink):
        self.sink = sink
        self.struct = fmi2CallbackFunctions()
        self._logger = fmi2CallbackLoggerTYPE(self._log)  # keep the thunk alive
        self.struct.logger = self._logger
        addLoggerProxy(byref(self.struct))

    def _log(self, env, instance_name, status, category, message):
        self.sink(instance_name.decode(), (STATUS_LABELS[status], category.decode(), message.decode()))


def capturing_logger():
    """A PythonLogger and the list it appends every (status label, category, message) to."""
    messages = []
    return PythonLogger(lambda name, entry: messages.append(entry)), messages


def named_drivers(driver, *names, **kwargs):
    """Drivers with the given instance names, each receiving its own log messages."""
    drivers = {name: driver(name=name, **kwargs) for name in names}
    router = PythonLogger(lambda name, entry: drivers[name].messages.append(entry))
    for d in drivers.values():
        d.log_router = router  # lives as long as the drivers
    return list(drivers.values())


# ---------------------------------------------------------------- 1. packaging


def test_fmpy_validate_reports_no_problem(fmu_path):
    """The model description must satisfy the FMI 2.0 schema and fmpy's semantic checks."""
    assert validate_fmu(str(fmu_path)) == []


def test_fmutool_check_reports_compliance(fmu_path):
    """fmu-manipulation-toolbox's XSD and semantic checks (FMI 2.0 sections 2.2.7, 2.2.8) pass."""
    done = subprocess.run([str(FMUTOOL), "-input", str(fmu_path), "-check"], capture_output=True, text=True, timeout=60)
    log = done.stdout + done.stderr
    assert done.returncode == 0, log
    assert "seems to be compliant with FMI-2.0" in log, log
    assert "No semantic error against the FMI-2 standard" in log, log
    assert not [line for line in log.splitlines() if line.startswith(("ERROR", "CRITICAL"))], log


def test_every_variable_has_a_declared_unit(model_description):
    """Every Real variable carries a unit (and display unit) defined in <UnitDefinitions>
    (section 2.2.2); Integer and Boolean variables, which FMI 2.0 gives no unit attribute, end
    their description with the unit in brackets; Enumeration variables have named items instead."""
    units = {u.name: u for u in model_description.unitDefinitions}
    for v in model_description.modelVariables:
        if v.type == "Enumeration":
            assert v.declaredType is not None and v.declaredType.items, f"{v.name}: an enumeration without items"
            continue
        if v.type != "Real":
            assert re.search(r"\[[^\]]+\]$", v.description or ""), f"{v.name}: description must end with [unit]"
            continue
        assert v.unit, f"{v.name} has no unit"
        assert v.unit in units, f"{v.name}: unit {v.unit!r} is not in UnitDefinitions"
        if v.displayUnit:
            assert v.displayUnit in {d.name for d in units[v.unit].displayUnits}, (v.name, v.displayUnit)


#: The enumeration types (FMI 2.0 section 2.2.3) with the codes the FMU has always used.
ENUMERATIONS = {
    "dispatch": ("Dispatch", {"equal": 1, "sequential": 2, "rotation": 3, "target": 4}),
    "belowMinimum": ("BelowMinimum", {"stayAtMinimum": 0, "standby": 1, "off": 2}),
    "operatingState": ("OperatingState", {"idle": 0, "starting": 1, "running": 2, "standby": 3, "stopping": 4}),
}


def test_enumerations_name_their_items_and_keep_the_integer_codes(fmu_path, model_description):
    """dispatch, belowMinimum and operatingState are Enumerations of named items with the codes
    scripts have always set through fmi2SetInteger; fmpy's dump shows the item names (in the
    descriptions), and its reader gives each variable its type's items."""
    variables = {v.name: v for v in model_description.modelVariables}
    for name, (type_name, items) in ENUMERATIONS.items():
        v = variables[name]
        assert (v.type, v.declaredType.name) == ("Enumeration", type_name), name
        assert {i.name: int(i.value) for i in v.declaredType.items} == items, name
        assert all(i.description for i in v.declaredType.items), name
    assert variables["dispatch"].start == "1" and variables["belowMinimum"].start == "0"
    dumped = fmu_info(str(fmu_path), causalities=["parameter", "output"])
    for name, (_, items) in ENUMERATIONS.items():
        line = next(line for line in dumped.splitlines() if line.split()[:1] == [name])
        assert all(item in line for item in items), (name, line)


@pytest.mark.parametrize(
    "name, code, label",
    [
        ("dispatch", 2, "sequential"),
        ("dispatch", 3, "rotation"),
        ("dispatch", 4, "target"),
        ("belowMinimum", 2, "off"),
    ],
)
def test_enumeration_parameters_set_as_integers_and_named_in_the_log(driver, name, code, label):
    """An Enumeration parameter is set with fmi2SetInteger by its item's value, read back as
    such, and the initialisation message names the items."""
    d = driver(logging_on=True)
    d.fmu.setupExperiment(startTime=0.0)
    settings = {"nModules": 4, "dispatch": 2, "belowMinimum": 1, name: code}
    d.fmu.setInteger([d.vr[n] for n in settings], list(settings.values()))
    d.set(setpoint=100.0)
    d.fmu.enterInitializationMode()
    assert d.fmu.getInteger([d.vr[name]]) == [code]
    d.fmu.exitInitializationMode()
    text = " ".join(m for _, _, m in d.messages)
    assert f"{name} {label}" in text, text
    assert d.fmu.getInteger([d.vr["operatingState"]]) == [ENUMERATIONS["operatingState"][1]["running"]]


def test_packaged_model_description_is_the_source_file(fmu_path):
    """The archive's modelDescription.xml is the repository's, byte for byte."""
    with zipfile.ZipFile(fmu_path) as z:
        packaged = z.read("modelDescription.xml")
    assert packaged == (ROOT / "modelDescription.xml").read_bytes()


def test_documentation_mentions_every_variable(fmu_path, model_description):
    """documentation/index.html (section 2.3, the FMU's entry point of documentation) exists and
    names every variable."""
    with zipfile.ZipFile(fmu_path) as z:
        if "documentation/index.html" not in z.namelist():
            pytest.xfail("documentation pending")
        html = z.read("documentation/index.html").decode("utf-8")
    missing = [v.name for v in model_description.modelVariables if v.name not in html]
    assert not missing, f"documentation/index.html does not mention {missing}"


def test_all_common_and_cosimulation_functions_are_exported(unzipdir, model_description, driver):
    """All 25 common and 9 co-simulation functions are exported (sections 2.1, 4.2)."""
    identifier = model_description.coSimulation.modelIdentifier
    library = Path(unzipdir, "binaries", platform, identifier + sharedLibraryExtension)
    nm = subprocess.run(["nm", "-D", "--defined-only", str(library)], capture_output=True, text=True, check=True)
    exported = {line.split()[-1] for line in nm.stdout.splitlines() if line.split()[-2:-1] == ["T"]}
    required = set(FMI2_COMMON_FUNCTIONS + FMI2_CS_FUNCTIONS)
    assert len(required) == 34
    assert required <= exported, f"missing: {sorted(required - exported)}"
    dll = driver().fmu.dll
    for name in sorted(required):
        assert getattr(dll, name) is not None


def test_version_and_types_platform(driver):
    """fmi2GetVersion returns "2.0" and fmi2GetTypesPlatform "default" (section 2.1.4)."""
    d = driver()
    assert d.fmu.getVersion() == "2.0"
    assert d.fmu.getTypesPlatform() == "default"


WRONG_GUID = b"{00000000-0000-0000-0000-000000000000}"


@pytest.mark.parametrize(
    "name, fmu_type, guid, words",
    [
        (b"aem", fmi2CoSimulation, WRONG_GUID, ("GUID",)),
        (b"aem", fmi2CoSimulation, None, ("GUID",)),
        (b"aem", fmi2ModelExchange, "model", ("fmuType", "co-simulation")),
        (b"", fmi2CoSimulation, "model", ("instanceName",)),
    ],
    ids=["wrong-guid", "null-guid", "model-exchange", "empty-name"],
)
def test_instantiate_refuses_with_null_and_a_message(driver, model_description, name, fmu_type, guid, words):
    """fmi2Instantiate returns NULL when it cannot serve the request, and says why through the
    logger it was given (section 2.1.5). guid "model" stands for the model description's GUID."""
    dll = driver().fmu.dll
    logger, messages = capturing_logger()
    if guid == "model":
        guid = model_description.guid.encode()
    component = dll.fmi2Instantiate(name, fmu_type, guid, b"file:///tmp", byref(logger.struct), 0, 1)
    assert component is None
    assert_logged(messages, FMI_ERROR, "fmi2Instantiate", *words)


# ---------------------------------------------------------------- 2. FMU state


def test_restored_state_continues_bit_for_bit(driver):
    """fmi2SetFMUstate restores everything: the continuation repeats exactly (section 2.1.8)."""
    d = driver(logging_on=True).initialize(setpoint=INITIAL_SETPOINT)
    run(d, PREFIX)
    t1, at_t1 = d.time, outputs(d)
    state = d.fmu.getFMUstate()
    first = run(d, CONTINUATION)

    d.fmu.setFMUstate(state)
    d.time = t1
    assert d.fmu.getRealStatus(fmi2LastSuccessfulTime) == t1
    assert_bit_identical([outputs(d)], [at_t1])
    assert_bit_identical(run(d, CONTINUATION), first)

    # The state survives being used: restoring it again repeats again.
    d.fmu.setFMUstate(state)
    d.time = t1
    assert_bit_identical(run(d, CONTINUATION), first)
    d.fmu.freeFMUstate(state)
    assert state.value is None, "fmi2FreeFMUstate must set the caller's pointer to NULL"


def test_serialized_state_continues_bit_for_bit_in_a_fresh_instance(driver):
    """A serialised state deserialised in another, freshly instantiated instance continues
    exactly like the original (section 2.1.8: states are portable between instances)."""
    d = driver(name="original").initialize(setpoint=INITIAL_SETPOINT, gain=0.6, rampUpLimit=0.4)
    run(d, PREFIX)
    t1 = d.time
    state = d.fmu.getFMUstate()
    blob = d.fmu.serializeFMUstate(state)
    d.fmu.freeFMUstate(state)
    expected = run(d, CONTINUATION)

    fresh = driver(name="fresh")  # instantiated only: never initialised
    restored = fresh.fmu.deSerializeFMUstate(blob)
    fresh.fmu.setFMUstate(restored)
    fresh.fmu.freeFMUstate(restored)
    fresh.time = t1
    assert snapshot(fresh) == blob
    assert fresh.fmu.getReal([VR_GAIN]) == [0.6]
    assert fresh.fmu.getRealStatus(fmi2LastSuccessfulTime) == t1
    assert_bit_identical(run(fresh, CONTINUATION), expected)


def test_get_fmu_state_overwrites_an_existing_state(driver):
    """fmi2GetFMUstate with *FMUstate != NULL reuses that state (section 2.1.8), and
    fmi2DeSerializeFMUstate may overwrite an existing state too."""
    d = driver().initialize(setpoint=INITIAL_SETPOINT)
    state = d.fmu.getFMUstate()
    address = state.value
    run(d, PREFIX)
    t2 = d.time
    assert call(d, "fmi2GetFMUstate", byref(state)) == FMI_OK
    assert state.value == address, "the existing state was not reused"
    expected = run(d, CONTINUATION)

    d.fmu.setFMUstate(state)
    d.time = t2
    assert_bit_identical(run(d, CONTINUATION), expected)

    # Overwrite via deserialisation: a state of t = 0 from a twin into the same pointer.
    twin = driver(name="twin").initialize(setpoint=INITIAL_SETPOINT)
    at_zero = snapshot(twin)
    d.fmu.deSerializeFMUstate(at_zero, state=state)
    assert state.value == address
    d.fmu.setFMUstate(state)
    d.time = 0.0
    assert_bit_identical(run(d, PREFIX), run(twin, PREFIX))
    d.fmu.freeFMUstate(state)
    assert state.value is None


def _flipped(position):
    def corrupt(blob, guid_length):
        b = bytearray(blob)
        b[position(len(blob), guid_length)] ^= 0xFF
        return bytes(b)

    return corrupt


def _resealed(edit):
    return lambda blob, guid_length: reseal(edit(bytearray(blob), guid_length))


def _set_u32(offset, value):
    def edit(b, guid_length):
        b[offset : offset + 4] = struct.pack("<I", value)
        return bytes(b)

    return edit


def _set_byte(offset_after_guid, value):
    def edit(b, guid_length):
        b[STATE_PAYLOAD + 4 + guid_length + offset_after_guid] = value
        return bytes(b)

    return edit


def _set_real(index, value):
    def edit(b, guid_length):
        at = STATE_PAYLOAD + 4 + guid_length + STATE_FLAGS + 8 * index
        b[at : at + 8] = struct.pack("<d", value)
        return bytes(b)

    return edit


def _other_guid(b, guid_length):
    at = STATE_PAYLOAD + 4 + 1  # first hex digit after "{"
    b[at] = ord("0") if b[at] != ord("0") else ord("1")
    return bytes(b)


#: name -> (corruption of the serialised bytes, words the refusal must mention)
CORRUPTIONS = {
    "flip-magic": (_flipped(lambda n, g: STATE_MAGIC), ("magic",)),
    "flip-version": (_flipped(lambda n, g: STATE_VERSION), ("version",)),
    "flip-length": (_flipped(lambda n, g: STATE_LENGTH), ("announces",)),
    "flip-guid": (_flipped(lambda n, g: STATE_PAYLOAD + 4 + 3), ("checksum",)),
    "flip-fmi-state": (_flipped(lambda n, g: STATE_PAYLOAD + 4 + g), ("checksum",)),
    "flip-real": (_flipped(lambda n, g: STATE_PAYLOAD + 4 + g + STATE_FLAGS + 8 * 6 + 3), ("checksum",)),
    "flip-crc": (_flipped(lambda n, g: n - 1), ("checksum",)),
    "truncated-to-empty": (lambda blob, g: b"", ("truncated",)),
    "truncated-header": (lambda blob, g: blob[:10], ("truncated",)),
    "truncated-by-one": (lambda blob, g: blob[:-1], ("announces",)),
    "truncated-half": (lambda blob, g: blob[: len(blob) // 2], ("announces",)),
    "extended-by-one": (lambda blob, g: blob + b"\0", ("announces",)),
    "wrong-version": (_resealed(_set_u32(STATE_VERSION, 2)), ("version 2",)),
    "other-guid": (_resealed(_other_guid), ("GUID",)),
    "unknown-fmi-state": (_resealed(_set_byte(0, 3)), ("FMI state",)),
    "invalid-flag": (_resealed(_set_byte(1, 7)), ("flag",)),
    "nan-real": (_resealed(_set_real(3, math.nan)), ("non-finite",)),
    "invalid-parameter": (_resealed(_set_real(0, 0.0)), ("gain",)),  # gain = 0
}


@pytest.mark.parametrize("corruption", list(CORRUPTIONS))
def test_corrupt_serialized_state_is_refused_and_changes_nothing(driver, model_description, corruption):
    """Corrupt, truncated, extended or foreign bytes are refused by fmi2DeSerializeFMUstate
    with fmi2Error and a reason; neither the instance nor a state it overwrites changes."""
    corrupt, words = CORRUPTIONS[corruption]
    probe, twin = named_drivers(driver, "probe", "twin", logging_on=True)
    for d in (probe, twin):
        d.initialize(setpoint=INITIAL_SETPOINT)
        run(d, PREFIX)
    existing = probe.fmu.getFMUstate()
    good = probe.fmu.serializeFMUstate(existing)
    guid_length = len(model_description.guid)
    assert len(good) == STATE_PAYLOAD + 4 + guid_length + STATE_FLAGS + STATE_AFTER_PARAMETERS + 4, (
        "layout assumed here is outdated"
    )
    bad = corrupt(good, guid_length)
    assert bad != good

    for target in (fmi2FMUstate(), existing):  # into a new state, then over an existing one
        before = target.value
        n = len(probe.messages)
        buffer = create_string_buffer(bad, len(bad)) if bad else None
        status = call(probe, "fmi2DeSerializeFMUstate", buffer, len(bad), byref(target))
        assert status == FMI_ERROR
        assert target.value == before
        assert_logged(probe.messages[n:], FMI_ERROR, "fmi2DeSerializeFMUstate", *words)

    assert probe.fmu.serializeFMUstate(existing) == good
    probe.fmu.freeFMUstate(existing)
    assert snapshot(probe) == snapshot(twin)
    assert_bit_identical(run(probe, CONTINUATION), run(twin, CONTINUATION))


def test_every_single_byte_flip_and_truncation_is_refused(driver):
    """No single flipped byte anywhere and no truncation to any length is accepted: the CRC-32
    and the header catch them all; the instance keeps continuing like its twin."""
    probe, twin = named_drivers(driver, "probe", "twin")
    for d in (probe, twin):
        d.initialize(setpoint=INITIAL_SETPOINT)
        run(d, PREFIX)
    good = snapshot(probe)
    variants = [good[:i] + bytes([good[i] ^ 0x01]) + good[i + 1 :] for i in range(len(good))]
    variants += [good[:n] for n in range(len(good))]
    for i, bad in enumerate(variants):
        target = fmi2FMUstate()
        buffer = create_string_buffer(bad, len(bad)) if bad else None
        status = call(probe, "fmi2DeSerializeFMUstate", buffer, len(bad), byref(target))
        assert (status, target.value) == (FMI_ERROR, None), f"variant {i} of {len(variants)} accepted"
    assert len([m for m in probe.messages if m[0] == "ERROR"]) == len(variants)
    assert snapshot(probe) == snapshot(twin)
    assert_bit_identical(run(probe, CONTINUATION), run(twin, CONTINUATION))


# ---------------------------------------------------------------- 3. independent instances


def test_interleaved_instances_equal_separate_runs(driver):
    """Instances share nothing (canBeInstantiatedOnlyOncePerProcess = false): two instances
    driven alternately give what each gives alone."""
    params_b = dict(gain=0.6, rampUpLimit=0.5, minSetpoint=50.0, tauPole1=3.0)
    schedule_a, schedule_b = make_schedule(10, 60), make_schedule(11, 60)

    alone_a = run(driver(name="a").initialize(setpoint=70.0), schedule_a)
    alone_b = run(driver(name="b").initialize(setpoint=95.0, **params_b), schedule_b)

    a, b = driver(name="a2"), driver(name="b2")
    a.fmu.setupExperiment(startTime=0.0)
    b.fmu.setupExperiment(startTime=0.0)
    b.set(setpoint=95.0, **params_b)
    a.set(setpoint=70.0)
    a.fmu.enterInitializationMode()
    b.fmu.enterInitializationMode()
    b.fmu.exitInitializationMode()
    a.fmu.exitInitializationMode()
    rows_a, rows_b = [], []
    for (ha, ua), (hb, ub) in zip(schedule_a, schedule_b):
        if ua is not None:
            a.set(setpoint=ua)  # a's input is set, then b makes a whole step, then a steps
        b.step(hb, setpoint=ub)
        a.step(ha)
        rows_b.append(outputs(b))
        rows_a.append(outputs(a))
    assert_bit_identical(rows_a, alone_a)
    assert_bit_identical(rows_b, alone_b)


# ---------------------------------------------------------------- 4. reset


def test_reset_returns_to_the_state_after_instantiate(driver, model_description):
    """After fmi2Reset the instance behaves as freshly instantiated (section 2.1.6): start values
    of parameters and input are back, and a new run equals a fresh instance's."""
    d = driver(logging_on=True)
    d.set(gain=0.6, rampUpLimit=0.5, maxSetpoint=90.0)  # set before initialisation, then reset
    d.initialize(setpoint=INITIAL_SETPOINT)
    run(d, PREFIX)
    d.fmu.reset()

    assert status_of(lambda: d.fmu.getReal([VR_CURRENT])) == FMI_ERROR, "not back in the instantiated state"
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.enterInitializationMode()
    start = {
        v.name: float(v.start) for v in model_description.modelVariables if v.start is not None and v.type == "Real"
    }
    assert d.get(*PARAMETER_NAMES) == [start[n] for n in PARAMETER_NAMES]
    assert d.get("setpoint") == start["setpoint"]
    d.set(setpoint=INITIAL_SETPOINT)
    d.fmu.exitInitializationMode()
    d.time = 0.0
    after_reset = [outputs(d)] + run(d, PREFIX + CONTINUATION)

    fresh = driver(name="fresh").initialize(setpoint=INITIAL_SETPOINT)
    assert_bit_identical(after_reset, [outputs(fresh)] + run(fresh, PREFIX + CONTINUATION))


# ---------------------------------------------------------------- 5. life cycles


def resident_bytes():
    """Resident set size of this process [bytes] (/proc/self/statm, second field)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def test_thousand_life_cycles_do_not_leak_or_drift(unzipdir, model_description):
    """1000 instantiate/initialise/step/state/terminate/free cycles in one process (library loaded
    once) give identical results each time, and resident memory stays flat."""
    fmu = FMU2Slave(
        guid=model_description.guid,
        unzipDirectory=unzipdir,
        modelIdentifier=model_description.coSimulation.modelIdentifier,
        instanceName="cycle",
    )
    logger, messages = capturing_logger()
    schedule = make_schedule(5, 8)
    first = None
    rss = {}
    try:
        for cycle in range(1, CYCLES + 1):
            fmu.instantiate(callbacks=logger.struct, loggingOn=False)
            fmu.setupExperiment(startTime=0.0)
            fmu.setReal([VR_SETPOINT, VR_GAIN], [INITIAL_SETPOINT, 0.55])
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            t = 0.0
            for h, u in schedule:
                if u is not None:
                    fmu.setReal([VR_SETPOINT], [u])
                fmu.doStep(t, h)
                t += h
            state = fmu.getFMUstate()
            copy = fmu.deSerializeFMUstate(fmu.serializeFMUstate(state))
            fmu.setFMUstate(copy)
            fmu.freeFMUstate(state)
            fmu.freeFMUstate(copy)
            assert fmu.dll.fmi2DoStep(fmu.component, t, -1.0, 1) == FMI_ERROR  # the error path too
            result = fmu.getReal(OUTPUT_VRS)
            fmu.terminate()
            fmu.fmi2FreeInstance(fmu.component)
            fmu.component = None
            if first is None:
                first = result
            assert _bits(result) == _bits(first), f"cycle {cycle} drifted: {result} != {first}"
            if cycle in (RSS_BASELINE_CYCLE, CYCLES):
                rss[cycle] = resident_bytes()
    finally:
        if fmu.component is not None:
            fmu.fmi2FreeInstance(fmu.component)
        fmu.freeLibrary()
    growth = rss[CYCLES] - rss[RSS_BASELINE_CYCLE]
    assert growth < MAX_RSS_GROWTH, (
        f"resident memory grew by {growth / 2**20:.1f} MiB over {CYCLES - RSS_BASELINE_CYCLE} cycles"
    )
    errors = [m for s, c, m in messages if s == "ERROR"]
    assert len(errors) == CYCLES and all("communicationStepSize" in m for m in errors), errors[:3]


# ---------------------------------------------------------------- 6. refused calls

INSTANTIATED, INITIALIZATION, STEP_COMPLETE, TERMINATED = (
    "instantiated",
    "initializationMode",
    "stepComplete",
    "terminated",
)


def bring_to(d, stage):
    """Drives a fresh instance into `stage`; in stepComplete it has run PREFIX."""
    if stage == INSTANTIATED:
        return
    d.fmu.setupExperiment(startTime=0.0)
    d.set(setpoint=INITIAL_SETPOINT)
    d.fmu.enterInitializationMode()
    if stage == INITIALIZATION:
        return
    d.fmu.exitInitializationMode()
    d.time = 0.0
    run(d, PREFIX)
    if stage == TERMINATED:
        d.fmu.terminate()


def continuation(d, stage):
    """From `stage`, the rest of a normal run: outputs now (where readable) and after each step."""
    if stage == TERMINATED:
        return [outputs(d)]
    if stage == INSTANTIATED:
        d.fmu.setupExperiment(startTime=0.0)
        d.set(setpoint=INITIAL_SETPOINT)
        d.fmu.enterInitializationMode()
    if stage in (INSTANTIATED, INITIALIZATION):
        d.fmu.exitInitializationMode()
        d.time = 0.0
    return [outputs(d)] + run(d, CONTINUATION)


@dataclass
class BadCall:
    """A call the FMU must refuse: the stage it is made in, the call (returning its fmi2Status),
    the status it must return and the words its log message must contain (None: nothing can
    be logged because there is no instance to log through)."""

    id: str
    stage: str
    action: Callable
    status: int = FMI_ERROR
    words: tuple = ()


def set_real(vrs, values):
    vrs, values = list(vrs), list(values)
    return lambda d: call(d, "fmi2SetReal", uints(*vrs), len(vrs), reals(*values))


def get_real(*vrs):
    return lambda d: call(d, "fmi2GetReal", uints(*vrs), len(vrs), reals(*[0.0] * len(vrs)))


def do_step(h, offset=0.0, relative=0.0):
    return lambda d: call(d, "fmi2DoStep", d.time + offset + relative * d.time, h, 1)


def plain(function, *args):
    return lambda d: call(d, function, *args)


def exit_with(**bad):
    """Sets a parameter set, tries fmi2ExitInitializationMode, then sets the start values back."""

    def action(d):
        d.set(**bad)
        try:
            return call(d, "fmi2ExitInitializationMode")
        finally:
            d.set(**{name: PAPER[name] for name in bad})

    return action


def with_state(use):
    """Runs `use(d, state)` on a fresh FMU state of d, then frees the state."""

    def action(d):
        state = d.fmu.getFMUstate()
        try:
            return use(d, state)
        finally:
            d.fmu.freeFMUstate(state)

    return action


def serialize_too_small(d, state):
    buffer = create_string_buffer(b"\x5a" * 16, 16)
    status = call(d, "fmi2SerializeFMUstate", state, buffer, 16)
    assert buffer.raw == b"\x5a" * 16, "the too-small buffer was written to"
    return status


def set_foreign_state(d):
    foreign = create_string_buffer(4096)  # zeros: not a state made by this FMU
    return call(d, "fmi2SetFMUstate", foreign)


def null_component(function, *args):
    return lambda d: getattr(d.fmu.dll, function)(None, *args)


def foreign_component(function, *args):
    def action(d):
        foreign = create_string_buffer(4096)  # zeros: not an instance made by this FMU
        return getattr(d.fmu.dll, function)(foreign, *args)

    return action


S = STEP_COMPLETE  # short alias for the table below
BAD_CALLS = [
    # Non-finite input and parameter values.
    *[
        BadCall(f"setpoint-{v}", S, set_real([VR_SETPOINT], [v]), words=("fmi2SetReal", "setpoint", "finite"))
        for v in (math.nan, math.inf, -math.inf)
    ],
    BadCall(
        "nan-parameter-init", INITIALIZATION, set_real([VR_GAIN], [math.nan]), words=("fmi2SetReal", "gain", "finite")
    ),
    BadCall("nan-parameter-instantiated", INSTANTIATED, set_real([103], [math.nan]), words=("tauPole2", "finite")),
    BadCall(
        "nan-setpoint-instantiated", INSTANTIATED, set_real([VR_SETPOINT], [math.nan]), words=("setpoint", "finite")
    ),
    # Unknown value references, outputs, atomicity of fmi2SetReal.
    *[
        BadCall(f"get-unknown-vr-{vr}", S, get_real(vr), words=("fmi2GetReal", f"value reference {vr}"))
        for vr in UNKNOWN_VRS
    ],
    *[
        BadCall(f"set-unknown-vr-{vr}", S, set_real([vr], [1.0]), words=("fmi2SetReal", f"value reference {vr}"))
        for vr in UNKNOWN_VRS
    ],
    BadCall("get-known-then-unknown", S, get_real(VR_CURRENT, 29), words=("value reference 29",)),
    BadCall("set-setpoint-then-unknown", S, set_real([VR_SETPOINT, 29], [90.0, 1.0]), words=("value reference 29",)),
    BadCall(
        "set-setpoint-then-output", S, set_real([VR_SETPOINT, VR_CURRENT], [90.0, 1.0]), words=("current", "output")
    ),
    *[BadCall(f"set-output-{vr}", S, set_real([vr], [1.0]), words=("fmi2SetReal", "output")) for vr in OUTPUT_VRS],
    BadCall("set-output-init", INITIALIZATION, set_real([VR_CURRENT], [1.0]), words=("current", "output")),
    # Step size and communication point.
    *[
        BadCall(f"step-size-{h}", S, do_step(h), words=("fmi2DoStep", "communicationStepSize"))
        for h in (-1.0, 0.0, -0.0, math.nan, math.inf, -math.inf)
    ],
    BadCall(
        "communication-point-plus-1s", S, do_step(1.0, offset=1.0), words=("fmi2DoStep", "currentCommunicationPoint")
    ),
    BadCall("communication-point-minus-1s", S, do_step(1.0, offset=-1.0), words=("currentCommunicationPoint",)),
    BadCall("communication-point-plus-1e-3t", S, do_step(1.0, relative=1e-3), words=("currentCommunicationPoint",)),
    BadCall("communication-point-minus-1e-3t", S, do_step(1.0, relative=-1e-3), words=("currentCommunicationPoint",)),
    # No Integer, Boolean or String variables exist.
    BadCall("get-integer", S, plain("fmi2GetInteger", uints(0), 1, ints(0)), words=("fmi2GetInteger", "Integer")),
    BadCall("set-integer", S, plain("fmi2SetInteger", uints(0), 1, ints(1)), words=("fmi2SetInteger", "Integer")),
    BadCall("get-boolean", S, plain("fmi2GetBoolean", uints(0), 1, ints(0)), words=("fmi2GetBoolean", "Boolean")),
    BadCall("set-boolean", S, plain("fmi2SetBoolean", uints(0), 1, ints(1)), words=("fmi2SetBoolean", "Boolean")),
    BadCall("get-string", S, plain("fmi2GetString", uints(0), 1, (c_char_p * 1)()), words=("fmi2GetString", "String")),
    BadCall(
        "set-string", S, plain("fmi2SetString", uints(0), 1, (c_char_p * 1)(b"x")), words=("fmi2SetString", "String")
    ),
    # Calls in the wrong state (section 4.2.4, state machine of a co-simulation slave).
    BadCall("do-step-instantiated", INSTANTIATED, do_step(1.0), words=("fmi2DoStep", "instantiated")),
    BadCall("get-real-instantiated", INSTANTIATED, get_real(VR_CURRENT), words=("fmi2GetReal", "instantiated")),
    BadCall(
        "exit-init-instantiated",
        INSTANTIATED,
        plain("fmi2ExitInitializationMode"),
        words=("fmi2ExitInitializationMode", "instantiated"),
    ),
    BadCall("terminate-instantiated", INSTANTIATED, plain("fmi2Terminate"), words=("fmi2Terminate", "instantiated")),
    BadCall("do-step-init", INITIALIZATION, do_step(1.0), words=("fmi2DoStep", "initializationMode")),
    BadCall(
        "enter-init-twice",
        INITIALIZATION,
        plain("fmi2EnterInitializationMode"),
        words=("fmi2EnterInitializationMode", "initializationMode"),
    ),
    BadCall(
        "setup-experiment-init",
        INITIALIZATION,
        plain("fmi2SetupExperiment", 0, 0.0, 0.0, 0, 0.0),
        words=("fmi2SetupExperiment", "initializationMode"),
    ),
    BadCall("set-parameter-after-init", S, set_real([VR_GAIN], [0.6]), words=("fmi2SetReal", "gain")),
    *[
        BadCall(f"set-{name}-after-init", S, set_real([vr], [PAPER[name]]), words=(name,))
        for name, vr in zip(PARAMETER_NAMES, PARAMETER_VRS)
    ],
    BadCall(
        "exit-init-twice", S, plain("fmi2ExitInitializationMode"), words=("fmi2ExitInitializationMode", "stepComplete")
    ),
    BadCall(
        "enter-init-after-init",
        S,
        plain("fmi2EnterInitializationMode"),
        words=("fmi2EnterInitializationMode", "stepComplete"),
    ),
    BadCall(
        "setup-experiment-after-init",
        S,
        plain("fmi2SetupExperiment", 0, 0.0, 0.0, 0, 0.0),
        words=("fmi2SetupExperiment", "stepComplete"),
    ),
    BadCall("do-step-terminated", TERMINATED, do_step(1.0), words=("fmi2DoStep", "terminated")),
    BadCall("set-real-terminated", TERMINATED, set_real([VR_SETPOINT], [90.0]), words=("fmi2SetReal", "terminated")),
    BadCall("terminate-twice", TERMINATED, plain("fmi2Terminate"), words=("fmi2Terminate", "terminated")),
    # Invalid parameter sets, refused at fmi2ExitInitializationMode naming the parameter.
    BadCall(
        "tauPole1-negative", INITIALIZATION, exit_with(tauPole1=-1.0), words=("fmi2ExitInitializationMode", "tauPole1")
    ),
    BadCall("min-above-max", INITIALIZATION, exit_with(minSetpoint=90.0, maxSetpoint=80.0), words=("minSetpoint",)),
    BadCall("equal-poles", INITIALIZATION, exit_with(tauPole1=50.0, tauPole2=50.0), words=("tauPole",)),
    BadCall("gain-zero", INITIALIZATION, exit_with(gain=0.0), words=("gain",)),
    BadCall("rampUpLimit-zero", INITIALIZATION, exit_with(rampUpLimit=0.0), words=("rampUpLimit",)),
    BadCall("nominalCurrent-negative", INITIALIZATION, exit_with(nominalCurrent=-1.0), words=("nominalCurrent",)),
    BadCall("ohmicResistance-negative", INITIALIZATION, exit_with(ohmicResistance=-0.1), words=("ohmicResistance",)),
    # Null and foreign pointers.
    BadCall("get-real-null-vr", S, plain("fmi2GetReal", None, 1, reals(0.0)), words=("fmi2GetReal", "vr", "null")),
    BadCall(
        "get-real-null-value",
        S,
        plain("fmi2GetReal", uints(VR_CURRENT), 1, None),
        words=("fmi2GetReal", "value", "null"),
    ),
    BadCall("set-real-null-vr", S, plain("fmi2SetReal", None, 1, reals(90.0)), words=("fmi2SetReal", "vr", "null")),
    BadCall(
        "set-real-null-value",
        S,
        plain("fmi2SetReal", uints(VR_SETPOINT), 1, None),
        words=("fmi2SetReal", "value", "null"),
    ),
    BadCall(
        "debug-logging-unknown-category",
        S,
        plain("fmi2SetDebugLogging", 1, 1, (c_char_p * 1)(b"logNonsense")),
        words=("fmi2SetDebugLogging", "logNonsense"),
    ),
    BadCall(
        "debug-logging-null-category",
        S,
        plain("fmi2SetDebugLogging", 1, 1, (c_char_p * 1)(None)),
        words=("fmi2SetDebugLogging", "null"),
    ),
    BadCall(
        "debug-logging-null-categories",
        S,
        plain("fmi2SetDebugLogging", 1, 2, None),
        words=("fmi2SetDebugLogging", "null"),
    ),
    BadCall("free-fmu-state-null", S, plain("fmi2FreeFMUstate", None), words=("fmi2FreeFMUstate", "null")),
    BadCall("get-fmu-state-null", S, plain("fmi2GetFMUstate", None), words=("fmi2GetFMUstate", "null")),
    BadCall("set-fmu-state-null", S, plain("fmi2SetFMUstate", None), words=("fmi2SetFMUstate", "null")),
    BadCall("set-fmu-state-foreign", S, set_foreign_state, words=("fmi2SetFMUstate", "not made by this FMU")),
    BadCall(
        "state-size-null",
        S,
        with_state(lambda d, s: call(d, "fmi2SerializedFMUstateSize", s, None)),
        words=("fmi2SerializedFMUstateSize", "null"),
    ),
    BadCall("serialize-too-small", S, with_state(serialize_too_small), words=("fmi2SerializeFMUstate", "too small")),
    BadCall(
        "serialize-null-buffer",
        S,
        with_state(lambda d, s: call(d, "fmi2SerializeFMUstate", s, None, 1024)),
        words=("fmi2SerializeFMUstate", "null"),
    ),
    BadCall(
        "deserialize-null-bytes",
        S,
        plain("fmi2DeSerializeFMUstate", None, 217, byref(fmi2FMUstate())),
        words=("fmi2DeSerializeFMUstate", "null"),
    ),
    BadCall(
        "real-status-null",
        S,
        plain("fmi2GetRealStatus", fmi2LastSuccessfulTime, None),
        words=("fmi2GetRealStatus", "null"),
    ),
    BadCall(
        "boolean-status-null",
        S,
        plain("fmi2GetBooleanStatus", fmi2Terminated, None),
        words=("fmi2GetBooleanStatus", "null"),
    ),
    BadCall("do-step-null-component", S, null_component("fmi2DoStep", 0.0, 1.0, 1), words=None),
    BadCall("get-real-null-component", S, null_component("fmi2GetReal", uints(1), 1, reals(0.0)), words=None),
    BadCall("set-real-null-component", S, null_component("fmi2SetReal", uints(0), 1, reals(90.0)), words=None),
    BadCall("reset-null-component", S, null_component("fmi2Reset"), words=None),
    BadCall("do-step-foreign-component", S, foreign_component("fmi2DoStep", 0.0, 1.0, 1), words=None),
    # Unsupported functions (model description: no derivatives, no asynchronous steps).
    # Input derivatives (canInterpolateInputs): only the first derivative of the input.
    BadCall(
        "input-derivative-order-0",
        S,
        plain("fmi2SetRealInputDerivatives", uints(0), 1, ints(0), reals(0.1)),
        words=("fmi2SetRealInputDerivatives", "order 0"),
    ),
    BadCall(
        "input-derivative-of-output",
        S,
        plain("fmi2SetRealInputDerivatives", uints(1), 1, ints(1), reals(0.1)),
        words=("fmi2SetRealInputDerivatives", "current", "not an input"),
    ),
    BadCall(
        "input-derivative-nan",
        S,
        plain("fmi2SetRealInputDerivatives", uints(0), 1, ints(1), reals(float("nan"))),
        words=("fmi2SetRealInputDerivatives", "finite"),
    ),
    BadCall(
        "input-derivative-terminated",
        TERMINATED,
        plain("fmi2SetRealInputDerivatives", uints(0), 1, ints(1), reals(0.1)),
        words=("fmi2SetRealInputDerivatives", "terminated"),
    ),
    BadCall(
        "get-real-output-derivatives",
        S,
        plain("fmi2GetRealOutputDerivatives", uints(1), 1, ints(1), reals(0.0)),
        words=("fmi2GetRealOutputDerivatives", "not supported"),
    ),
    BadCall(
        "get-directional-derivative",
        S,
        plain("fmi2GetDirectionalDerivative", uints(1), 1, uints(0), 1, reals(1.0), reals(0.0)),
        words=("fmi2GetDirectionalDerivative", "not supported"),
    ),
    BadCall("cancel-step", S, plain("fmi2CancelStep"), words=("fmi2CancelStep",)),
    # Status kinds that are not available: fmi2Discard (section 4.2.3).
    BadCall(
        "status-do-step", S, plain("fmi2GetStatus", fmi2DoStepStatus, byref(c_int(0))), FMI_DISCARD, ("fmi2GetStatus",)
    ),
    BadCall(
        "status-pending", S, plain("fmi2GetStatus", fmi2PendingStatus, byref(c_int(0))), FMI_DISCARD, ("fmi2GetStatus",)
    ),
    BadCall(
        "real-status-do-step",
        S,
        plain("fmi2GetRealStatus", fmi2DoStepStatus, byref(c_double(0))),
        FMI_DISCARD,
        ("fmi2GetRealStatus",),
    ),
    BadCall(
        "integer-status",
        S,
        plain("fmi2GetIntegerStatus", fmi2DoStepStatus, byref(c_int(0))),
        FMI_DISCARD,
        ("fmi2GetIntegerStatus",),
    ),
    BadCall(
        "string-status",
        S,
        plain("fmi2GetStringStatus", fmi2PendingStatus, byref(c_char_p())),
        FMI_DISCARD,
        ("fmi2GetStringStatus",),
    ),
]


@pytest.mark.parametrize("case", BAD_CALLS, ids=lambda c: c.id)
def test_refused_call_logs_why_and_changes_nothing(driver, case):
    """A refused call returns fmi2Error (fmi2Discard for unavailable status kinds), logs the reason
    in category logStatusError/logStatusDiscard, and leaves the instance exactly as it was: its
    state and its whole continuation equal those of an undisturbed twin."""
    probe, twin = named_drivers(driver, "probe", "twin", logging_on=True)
    bring_to(probe, case.stage)
    bring_to(twin, case.stage)
    n = len(probe.messages)

    status = case.action(probe)

    assert status == case.status, f"{case.id}: returned {STATUS_LABELS[status]}, expected {STATUS_LABELS[case.status]}"
    if case.words is not None:
        assert_logged(probe.messages[n:], case.status, *case.words)
    assert snapshot(probe) == snapshot(twin), "the refused call changed the instance's state"
    assert_bit_identical(continuation(probe, case.stage), continuation(twin, case.stage))


def test_status_inquiry(driver):
    """fmi2GetRealStatus(fmi2LastSuccessfulTime) is the time reached; fmi2GetBooleanStatus
    (fmi2Terminated) is false: the slave never asks to stop (section 4.2.3)."""
    d = driver().initialize(setpoint=INITIAL_SETPOINT)
    assert d.fmu.getRealStatus(fmi2LastSuccessfulTime) == 0.0
    run(d, PREFIX)
    assert d.fmu.getRealStatus(fmi2LastSuccessfulTime) == d.time
    assert d.fmu.getBooleanStatus(fmi2Terminated) is False
    d.fmu.terminate()
    assert d.fmu.getRealStatus(fmi2LastSuccessfulTime) == d.time


def test_start_time_shifts_time_only(driver):
    """fmi2SetupExperiment(startTime) sets where time begins: communication points count from it,
    fmi2LastSuccessfulTime reports it, and the outputs equal a run started at 0."""
    late, early = named_drivers(driver, "late", "early")
    late.initialize(setpoint=INITIAL_SETPOINT, start_time=1000.0)
    early.initialize(setpoint=INITIAL_SETPOINT)
    assert late.fmu.getRealStatus(fmi2LastSuccessfulTime) == 1000.0
    assert status_of(lambda: late.fmu.doStep(0.0, 1.0)) == FMI_ERROR  # time 0 is not the FMU's time
    assert_bit_identical(run(late, PREFIX), run(early, PREFIX))
    assert late.fmu.getRealStatus(fmi2LastSuccessfulTime) == late.time


# ---------------------------------------------------------------- 7. logging


def event_messages(messages):
    return [m for s, c, m in messages if c == "logEvents"]


def test_log_events_category_switches_on_and_off(driver):
    """fmi2SetDebugLogging(true, {logEvents}) makes model events appear; (false, {logEvents})
    removes them again (section 2.1.5)."""
    d = driver(logging_on=False)
    d.fmu.setDebugLogging(True, ["logEvents"])
    d.initialize(setpoint=INITIAL_SETPOINT)
    assert any("initialised" in m for m in event_messages(d.messages)), d.messages

    d.fmu.setDebugLogging(False, ["logEvents"])
    n = len(d.messages)
    d.fmu.reset()
    d.initialize(setpoint=INITIAL_SETPOINT)
    d.step(1.0, setpoint=120.0)  # leaves the window: a warning
    d.step(1.0, setpoint=90.0)  # back in the window: a logEvents message if enabled
    assert event_messages(d.messages[n:]) == []


def test_debug_logging_with_categories_outputs_only_those(driver):
    """Section 2.1.5: "If loggingOn = fmi2True and nCategories > 0, then only debug messages
    according to the categories argument shall be output": after (true, {logEvents}) and then
    (true, {logStatusWarning}), logEvents messages are no longer output."""
    d = driver(logging_on=False)
    d.fmu.setDebugLogging(True, ["logEvents"])
    d.fmu.setDebugLogging(True, ["logStatusWarning"])
    d.initialize(setpoint=INITIAL_SETPOINT)
    d.step(1.0, setpoint=120.0)
    d.step(1.0, setpoint=90.0)
    assert event_messages(d.messages) == []


def test_debug_logging_is_off_unless_requested(driver):
    """loggingOn = false at fmi2Instantiate: no debug messages."""
    d = driver(logging_on=False).initialize(setpoint=INITIAL_SETPOINT)
    d.step(1.0, setpoint=120.0)
    d.step(1.0, setpoint=90.0)
    assert event_messages(d.messages) == []


def test_switching_log_events_off_after_logging_on_at_instantiation(driver):
    """loggingOn = true at fmi2Instantiate switches on every category; switching off logEvents
    afterwards must stop the logEvents messages."""
    d = driver(logging_on=True)
    d.fmu.setDebugLogging(False, ["logEvents"])
    d.initialize(setpoint=INITIAL_SETPOINT)
    d.step(1.0, setpoint=120.0)
    d.step(1.0, setpoint=90.0)
    assert event_messages(d.messages) == []


def test_all_categories_off_silences_debug_messages(driver):
    """fmi2SetDebugLogging(false, nCategories = 0) switches every debug category off."""
    d = driver(logging_on=True)
    d.fmu.setDebugLogging(False, [])
    d.initialize(setpoint=INITIAL_SETPOINT)
    d.step(1.0, setpoint=120.0)
    d.step(1.0, setpoint=90.0)
    assert event_messages(d.messages) == []


def test_errors_and_warnings_are_logged_regardless(driver):
    """Warnings and errors reach the logger whatever the debug-logging setting."""
    d = driver(logging_on=False)
    d.fmu.setDebugLogging(False, [])
    d.initialize(setpoint=INITIAL_SETPOINT)
    n = len(d.messages)
    assert status_of(lambda: d.fmu.doStep(d.time, -1.0)) == FMI_ERROR
    assert_logged(d.messages[n:], FMI_ERROR, "fmi2DoStep", "communicationStepSize")
    n = len(d.messages)
    assert call(d, "fmi2SetReal", uints(VR_SETPOINT), 1, reals(120.0)) == FMI_WARNING
    assert_logged(d.messages[n:], FMI_WARNING, "setpoint", "120")


def test_refused_set_debug_logging_changes_no_category(driver):
    """A category list with an unknown name is refused as a whole: logEvents stays on."""
    d = driver(logging_on=False)
    d.fmu.setDebugLogging(True, ["logEvents"])
    assert status_of(lambda: d.fmu.setDebugLogging(False, ["logEvents", "logNonsense"])) == FMI_ERROR
    d.initialize(setpoint=INITIAL_SETPOINT)
    assert any("initialised" in m for m in event_messages(d.messages)), d.messages


# ---------------------------------------------------------------- 8. simulate_fmu

SIM_STOP = 6000.0  # [s]; the last setpoint step is 3500 s = 30 tauPole2 before the end
SIM_INTERVAL = 5.0  # [s]
RISE_AT, FALL_AT = 300.0, 2500.0  # [s]
LOW, HIGH, FINAL = 60.0, 100.0, 75.0  # setpoints [%]


def test_simulate_fmu_with_a_setpoint_table(fmu_path):
    """fmpy.simulate_fmu drives the FMU end to end with a step table: steady start, rate-limited
    rise, free fall following the closed-form step response, and final current K·setpoint."""
    signal = np.array(
        [(0.0, LOW), (RISE_AT, LOW), (RISE_AT, HIGH), (FALL_AT, HIGH), (FALL_AT, FINAL), (SIM_STOP, FINAL)],
        dtype=[("time", np.float64), ("setpoint", np.float64)],
    )
    result = simulate_fmu(
        str(fmu_path),
        start_time=0.0,
        stop_time=SIM_STOP,
        output_interval=SIM_INTERVAL,
        input=signal,
        output=list(OUTPUT_NAMES),
        fmi_type="CoSimulation",
    )
    t, current, voltage = result["time"], result["current"], result["voltage"]
    k = PAPER["gain"]
    assert t[-1] == pytest.approx(SIM_STOP)
    assert current[0] == pytest.approx(k * LOW, rel=1e-12)
    assert current[-1] == pytest.approx(k * FINAL, rel=1e-9)
    assert voltage[-1] == pytest.approx(PAPER["voltageIntercept"] + PAPER["ohmicResistance"] * k * FINAL, rel=1e-9)
    rise = np.diff(current) / np.diff(t)
    assert rise.max() <= PAPER["rampUpLimit"] * (1 + 1e-9)
    assert rise.max() >= PAPER["rampUpLimit"] * (1 - 1e-9), "the rate limit never became binding"
    falling = (t > FALL_AT) & (t <= FALL_AT + 600.0)
    expected = [unlimited_step_response(HIGH, FINAL, s - FALL_AT) for s in t[falling]]
    np.testing.assert_allclose(current[falling], expected, rtol=0, atol=1e-6)
