"""The packaged FMU in three independent importers, and its memory under valgrind.

1. The setpoint schedule of tests/data/importer_schedule.csv runs through
   - a C master compiled here against the FMI 2.0 headers of the fmi-sys crate
     (tests/c_master: dlopen, all 34 functions resolved, every status checked),
   - the `fmi` crate (examples/fmi_crate_master.rs, as the Rust tests built it),
   - fmpy's FMU2Slave (in this process),
   with the same communication points, and the three outputs must be identical bit for bit:
   it is one binary doing the same arithmetic, so any difference is an importer calling it
   differently. Closed-form responses then check the numbers themselves, so three importers
   that agree on a wrong answer still fail.
2. The C master runs 10 000 instantiate/step/free cycles under valgrind memcheck: no leak
   (definite, indirect or possible) and no invalid access. "Still reachable" blocks (memory a
   runtime keeps for the life of the process) are not leaks and are only reported. The same
   cycles run natively under AddressSanitizer/LeakSanitizer. Each checker is first shown to
   catch a deliberate leak and a deliberate out-of-bounds read.
"""

import csv
import json
import math
import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import PAPER, ROOT, Driver, modal_weights, unlimited_step_response

# the fmi crate's master built by the Rust tests, valgrind
pytestmark = [pytest.mark.slow]

SCHEDULE = ROOT / "tests" / "data" / "importer_schedule.csv"
FMI_CRATE_MASTER = (
    Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    / "x86_64-unknown-linux-gnu"
    / "release"
    / "examples"
    / "fmi_crate_master"
)
STEP, STOP = 0.5, 1500.0
COLUMNS = ("time", "current", "voltage", "power", "h2Flow", "energy", "h2Produced")
C_SOURCES = [ROOT / "tests" / "c_master" / name for name in ("master.c", "fmu.c", "bad_calls.c")]
C_FLAGS = ["-std=c11", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-g"]

CYCLES = 10_000
VALGRIND = [
    "valgrind",
    "--leak-check=full",
    "--show-leak-kinds=definite,indirect,possible",
    "--errors-for-leak-kinds=definite,indirect,possible",
    "--error-exitcode=99",
    "--keep-debuginfo=yes",  # readable stacks for blocks allocated by the unloaded FMU
]

#: Currents [A]: the FMU integrates in closed form, so only rounding separates it from the math.
CURRENT_ABS_TOL = 1e-9
#: Relative tolerance on algebraic outputs and on the integrals (energy, hydrogen).
REL_TOL = 1e-9


def require(tool):
    path = shutil.which(tool)
    if path is None:
        pytest.fail(f"{tool} is not installed (scripts/setup.sh installs it)")
    return path


def run(cmd, **kwargs):
    """Runs a command; on failure the assertion shows its output."""
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kwargs)
    assert done.returncode == 0, f"{cmd[0]} exited with {done.returncode}\n{done.stdout}\n{done.stderr}"
    return done


# ------------------------------------------------------------------------------ fixtures


@pytest.fixture(scope="module")
def fmi_headers():
    """fmi-standard2/headers of the fmi-sys crate that this package builds against."""
    meta = json.loads(run(["cargo", "metadata", "--format-version", "1", "--locked"], cwd=ROOT).stdout)
    (fmi_sys,) = [p for p in meta["packages"] if p["name"] == "fmi-sys"]
    headers = Path(fmi_sys["manifest_path"]).parent / "fmi-standard2" / "headers"
    assert (headers / "fmi2FunctionTypes.h").is_file(), headers
    return headers


@pytest.fixture(scope="module")
def fmu_dir(fmu_path, tmp_path_factory):
    """The .fmu extracted with the standard library's zipfile (independent of fmpy)."""
    target = tmp_path_factory.mktemp("c_master_fmu")
    with zipfile.ZipFile(fmu_path) as fmu:
        fmu.extractall(target)
    return target


@pytest.fixture(scope="module")
def build_c_master(fmi_headers, tmp_path_factory):
    """Compiles tests/c_master with extra flags; returns the executable."""
    gcc = require("gcc")
    out_dir = tmp_path_factory.mktemp("c_master")

    def build(name, *extra_flags):
        exe = out_dir / name
        run([gcc, *C_FLAGS, *extra_flags, f"-I{fmi_headers}", *C_SOURCES, "-o", exe, "-ldl", "-lm"])
        return exe

    return build


@pytest.fixture(scope="module")
def c_master(build_c_master):
    return build_c_master("master", "-O2")


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == COLUMNS, rows[0]
    return np.array([[float(x) for x in row] for row in rows[1:]])


def read_schedule():
    with open(SCHEDULE, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["time", "setpoint"]
    return [(float(t), float(u)) for t, u in rows[1:] if t.strip()]


def run_c_master(c_master, fmu_dir, out):
    run([c_master, "--fmu-dir", fmu_dir, "--schedule", SCHEDULE, "--step", STEP, "--stop", STOP, "--out", out])
    return read_csv(out)


def run_fmi_crate(fmu_path, out):
    # The example as the Rust tests built it (cargo test builds the examples; scripts/test.sh
    # runs them as packaging/platforms.py test: linux64, bench profile). The numbers come from
    # the packaged FMU's binary, whichever profile built the master.
    if not FMI_CRATE_MASTER.is_file():
        pytest.fail(f"{FMI_CRATE_MASTER} not found: scripts/test.sh builds it (packaging/platforms.py test)")
    run(
        [FMI_CRATE_MASTER, "--fmu", fmu_path, "--schedule", SCHEDULE, "--step", STEP, "--stop", STOP, "--out", out],
        cwd=ROOT,
    )
    return read_csv(out)


def run_fmpy(unzipdir, model_description):
    """The same schedule semantics as the C and Rust masters: the setpoint in force at t is
    that of the last row with time <= t; communication points are start + n*h."""
    schedule = read_schedule()
    start = schedule[0][0]

    def setpoint_at(t):
        return [u for (ts, u) in schedule if ts <= t][-1]

    d = Driver(unzipdir, model_description, name="fmpy_importer")
    fmu, vr = d.fmu, d.vr
    outputs = [vr[name] for name in COLUMNS[1:]]
    fmu.setupExperiment(startTime=start, stopTime=STOP)
    fmu.setReal([vr["setpoint"]], [setpoint_at(start)])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    rows = [[start, *fmu.getReal(outputs)]]
    n_steps = round((STOP - start) / STEP)
    for n in range(n_steps):
        t = start + n * STEP
        fmu.setReal([vr["setpoint"]], [setpoint_at(t)])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
        rows.append([start + (n + 1) * STEP, *fmu.getReal(outputs)])
    d.free()
    errors = [m for m in d.messages if m[0] not in ("OK", "WARNING")]
    assert not errors, errors
    return np.array(rows)


@pytest.fixture(scope="module")
def runs(c_master, fmu_dir, fmu_path, unzipdir, model_description, tmp_path_factory):
    out = tmp_path_factory.mktemp("importer_runs")
    return {
        "C master": run_c_master(c_master, fmu_dir, out / "c.csv"),
        "fmi crate": run_fmi_crate(fmu_path, out / "fmi_crate.csv"),
        "fmpy": run_fmpy(unzipdir, model_description),
    }


# ------------------------------------------------------------------------------ same numbers


def test_three_importers_agree_bit_for_bit(runs):
    reference = runs["fmpy"]
    n_rows = round(STOP / STEP) + 1
    assert reference.shape == (n_rows, len(COLUMNS))
    for name, result in runs.items():
        assert result.shape == reference.shape, name
        # Compare the bit patterns: equal doubles, and no NaN hiding in both.
        differ = result.view(np.uint64) != reference.view(np.uint64)
        if differ.any():
            row, col = np.argwhere(differ)[0]
            pytest.fail(
                f"{name} differs from fmpy in {differ.sum()} values; first at t = {reference[row, 0]} s, "
                f"{COLUMNS[col]}: {result[row, col]!r} vs {reference[row, col]!r}"
            )
    assert np.isfinite(reference).all()


# ------------------------------------------------------------------------------ right numbers


def column(result, name):
    return result[:, COLUMNS.index(name)]


def exp_sum_integrals(y, amp1, amp2, tau1, tau2, t):
    """For x(s) = y + A e^(-s/tau1) + B e^(-s/tau2) on [0, t]: (int x ds, int x^2 ds)."""
    g1, g2 = -math.expm1(-t / tau1), -math.expm1(-t / tau2)
    tau12 = tau1 * tau2 / (tau1 + tau2)
    int_x = y * t + amp1 * tau1 * g1 + amp2 * tau2 * g2
    int_x2 = (
        y * y * t
        + 2 * y * (amp1 * tau1 * g1 + amp2 * tau2 * g2)
        + amp1 * amp1 * tau1 / 2 * -math.expm1(-2 * t / tau1)
        + amp2 * amp2 * tau2 / 2 * -math.expm1(-2 * t / tau2)
        + 2 * amp1 * amp2 * tau12 * -math.expm1(-t / tau12)
    )
    return int_x, int_x2


def test_schedule_follows_the_closed_form(runs):
    """Steady state at 90 % for 10 s, then the negative step 90 -> 65 % (no rate limit):
        I(s) = K u1 + K (u0 - u1)(a e^(-s/tp1) + b e^(-s/tp2)),  a = (tz - tp1)/(tp2 - tp1), b = 1 - a,
    with energy = int (V0 + R I) I dt and hydrogen = c int I dt / 3600 in closed form; then the
    step up to 100 % at t = 700 s rises at exactly rampUpLimit while the limit binds."""
    result = runs["fmpy"]  # identical to the other two (previous test)
    p = PAPER
    k, v0, r_ohm, c = p["gain"], p["voltageIntercept"], p["ohmicResistance"], p["h2Coefficient"]
    t, current = column(result, "time"), column(result, "current")
    assert read_schedule()[:3] == [(0.0, 90.0), (10.0, 65.0), (700.0, 100.0)], "the checks below assume this"

    # Algebraic outputs everywhere.
    voltage = v0 + r_ohm * current
    np.testing.assert_allclose(column(result, "voltage"), voltage, rtol=REL_TOL, atol=0)
    np.testing.assert_allclose(column(result, "power"), voltage * current, rtol=REL_TOL, atol=0)
    np.testing.assert_allclose(column(result, "h2Flow"), c * current, rtol=REL_TOL, atol=0)

    i0 = k * 90.0
    steady = t <= 10.0
    np.testing.assert_allclose(current[steady], i0, rtol=0, atol=CURRENT_ABS_TOL)

    a, b = modal_weights(p)
    for ti, ii, energy, h2 in zip(t, current, column(result, "energy"), column(result, "h2Produced")):
        if not 10.0 < ti <= 700.0:
            continue
        s = ti - 10.0
        want = unlimited_step_response(90.0, 65.0, s)
        assert abs(ii - want) <= CURRENT_ABS_TOL, f"t = {ti} s: {ii!r} A vs {want!r} A"
        if ti in (10.5, 50.0, 200.0, 700.0):
            amp = k * (90.0 - 65.0)
            q, q2 = exp_sum_integrals(k * 65.0, amp * a, amp * b, p["tauPole1"], p["tauPole2"], s)
            want_energy = (v0 + r_ohm * i0) * i0 * 10.0 + v0 * q + r_ohm * q2
            want_h2 = c * (i0 * 10.0 + q) / 3600.0
            assert energy == pytest.approx(want_energy, rel=REL_TOL, abs=0), f"energy at t = {ti} s"
            assert h2 == pytest.approx(want_h2, rel=REL_TOL, abs=0), f"h2Produced at t = {ti} s"

    # Step up at 700 s: the response would rise at up to ~8 A/s; the limit holds it to
    # 0.22 A/s until the ramp meets the response, about 78 s later.
    i700 = current[t == 700.0][0]
    ramp = (t > 700.0) & (t <= 760.0)
    np.testing.assert_allclose(current[ramp], i700 + p["rampUpLimit"] * (t[ramp] - 700.0), rtol=0, atol=1e-9)


# ------------------------------------------------------------------------------ memory


def valgrind_report(log):
    """(errors, {definitely, indirectly, possibly, still reachable: bytes}) from a memcheck log."""
    text = Path(log).read_text()
    errors = re.findall(r"ERROR SUMMARY: ([\d,]+) errors", text)
    assert errors, f"no ERROR SUMMARY in the valgrind log:\n{text}"
    lost = {kind: 0 for kind in ("definitely", "indirectly", "possibly", "still reachable")}
    if "All heap blocks were freed -- no leaks are possible" not in text:
        for kind in lost:
            found = re.search(rf"{kind}(?: lost)?: ([\d,]+) bytes", text)
            assert found, f"no '{kind}' figure in the valgrind log:\n{text}"
            lost[kind] = int(found.group(1).replace(",", ""))
    return int(errors[-1].replace(",", "")), lost, text


def run_valgrind(c_master, fmu_dir, log, cycles, *extra):
    require("valgrind")
    cmd = [*VALGRIND, f"--log-file={log}", c_master, "--fmu-dir", fmu_dir, "--cycles", cycles, *extra]
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    return done, *valgrind_report(log)


@pytest.mark.parametrize("inject", ["leak", "invalid-read"])
def test_valgrind_catches_a_deliberate_fault(c_master, fmu_dir, tmp_path, inject):
    """The harness below can fail: one lost FMU state, or one byte read out of bounds."""
    done, errors, lost, text = run_valgrind(c_master, fmu_dir, tmp_path / "vg.log", 3, "--inject", inject)
    assert done.returncode == 99, (done.returncode, done.stderr)
    assert errors >= 1
    if inject == "leak":
        assert lost["definitely"] > 0, text
    else:
        assert "Invalid read of size 1" in text, text


def test_ten_thousand_cycles_under_valgrind_leak_nothing(c_master, fmu_dir, tmp_path):
    """Each cycle: a refused instantiation, instantiate, debug logging, initialise, steps with
    a changing (once clamped) setpoint, FMU state get/update/serialise/deserialise/set/free, a
    corrupted state, a NaN setpoint, an unknown value reference and a doStep at the wrong time
    (each refused with fmi2Error and a message), terminate, reset, free (see master.c)."""
    done, errors, lost, text = run_valgrind(c_master, fmu_dir, tmp_path / "vg.log", CYCLES)
    assert f"cycles: {CYCLES}," in done.stdout, (done.stdout, done.stderr)
    assert done.returncode == 0, f"exit {done.returncode}\n{done.stderr}\n{text}"
    assert errors == 0, text
    leaked = {kind: n for kind, n in lost.items() if kind != "still reachable" and n}
    assert not leaked, text
    print(f"valgrind: {CYCLES} cycles, 0 errors, still reachable {lost['still reachable']} bytes")


@pytest.fixture(scope="module")
def asan_master(build_c_master):
    exe = build_c_master("master_asan", "-O1", "-fsanitize=address", "-fno-omit-frame-pointer")
    # Old sanitizer runtimes crash at start-up on kernels with high mmap randomisation
    # (vm.mmap_rnd_bits > 28); that is the host, not the FMU, and valgrind covers it all.
    usage = subprocess.run([str(exe)], capture_output=True, text=True)
    if usage.returncode != 2 or "usage:" not in usage.stderr:
        pytest.skip(f"AddressSanitizer does not run on this host: {usage.stderr[-500:]}")
    return exe


def run_asan(asan_master, fmu_dir, cycles, *extra):
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=1:exitcode=98")
    cmd = [asan_master, "--fmu-dir", fmu_dir, "--cycles", cycles, *extra]
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env)


@pytest.mark.parametrize("inject, words", [("leak", "detected memory leaks"), ("invalid-read", "heap-buffer-overflow")])
def test_address_sanitizer_catches_a_deliberate_fault(asan_master, fmu_dir, inject, words):
    done = run_asan(asan_master, fmu_dir, 3, "--inject", inject)
    assert done.returncode != 0 and words in done.stderr, (done.returncode, done.stderr)


def test_ten_thousand_cycles_under_leak_sanitizer_leak_nothing(asan_master, fmu_dir):
    """The same cycles natively with LeakSanitizer (catches leaks of the FMU's allocations, which
    it intercepts; out-of-bounds access inside the uninstrumented FMU is valgrind's job)."""
    done = run_asan(asan_master, fmu_dir, CYCLES)
    assert done.returncode == 0, done.stderr
    assert f"cycles: {CYCLES}," in done.stdout
