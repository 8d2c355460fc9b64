"""The packaged FMU on every desk: its linux64 binary needs glibc 2.17 at most, and its win64
DLL, run under Wine (Debian's wine64) by the C master cross-compiled with mingw-w64, gives the
linux64 binary's outputs bit for bit, the same memory-cycle counts, the same answers to every
bad call of docs/robustness.md, and understands Windows paths and file URIs. aem-identify.exe
(packaging/platforms.py) identifies the same parameters as the Linux build, from LF and CRLF
files alike.

Wine 8.0 lacks bcryptprimitives.dll, which Rust's standard library imports on Windows (every
Windows 10 and later has it): tests/windows/bcryptprimitives.c, built here, stands in for it on
Wine's search path and is never shipped."""

import json
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, windows_path

# the win64 binaries under Wine and the glibc level of the release builds
pytestmark = [pytest.mark.wine]

MODEL = "AemElectrolyser"
WINE = Path("/usr/lib/wine/wine64")
MINGW_GCC = "x86_64-w64-mingw32-gcc"
MINGW_OBJDUMP = "x86_64-w64-mingw32-objdump"
C_SOURCES = [ROOT / "tests" / "c_master" / name for name in ("master.c", "fmu.c", "bad_calls.c")]
C_FLAGS = ["-std=c11", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-O2"]
SCHEDULE = ROOT / "tests" / "data" / "importer_schedule.csv"
IDENTIFY_EXE = ROOT / "target" / "dist" / "win64" / "aem-identify.exe"
IDENTIFY_LINUX = ROOT / "target" / "dist" / "linux64" / "aem-identify"
RUN_EXE = ROOT / "target" / "dist" / "win64" / "aem-run.exe"
RUN_LINUX64 = ROOT / "target" / "dist" / "linux64" / "aem-run"
#: The Python package's native stepping loop (crates/drive), as the release builds it.
DRIVE_DLL = ROOT / "target" / "dist" / "win64" / "aem_drive.dll"
DRIVE_LINUX64 = ROOT / "target" / "dist" / "linux64" / "libaem_drive.so"
#: DLLs every Windows 10 and later has; the FMU's DLL may import these and no others.
SYSTEM_DLLS = {
    "kernel32.dll",
    "ntdll.dll",
    "msvcrt.dll",
    "userenv.dll",
    "ws2_32.dll",
    "bcryptprimitives.dll",
    "api-ms-win-core-synch-l1-2-0.dll",
    "advapi32.dll",
    "bcrypt.dll",
}


def require(tool):
    path = shutil.which(tool) or (str(tool) if Path(tool).is_file() else None)
    if path is None:
        pytest.fail(f"{tool} is not installed (scripts/setup.sh installs it)")
    return path


def run(cmd, timeout=300, **kwargs):
    done = subprocess.run([str(c) for c in cmd], capture_output=True, timeout=timeout, **kwargs)
    assert done.returncode == 0, (
        f"{cmd}\nexit {done.returncode}\n{done.stdout.decode(errors='replace')}\n{done.stderr.decode(errors='replace')}"
    )
    return done.stdout.decode(errors="replace")


# ------------------------------------------------------------------------------ fixtures


@pytest.fixture(scope="module")
def fmi_headers():
    meta = json.loads(run(["cargo", "metadata", "--format-version", "1", "--locked"], cwd=ROOT))
    (fmi_sys,) = [p for p in meta["packages"] if p["name"] == "fmi-sys"]
    return Path(fmi_sys["manifest_path"]).parent / "fmi-standard2" / "headers"


@pytest.fixture(scope="module")
def fmu_dir(fmu_path, tmp_path_factory):
    """The .fmu extracted with zipfile, into a folder whose name needs percent-encoding."""
    target = tmp_path_factory.mktemp("platforms") / "fmu dir"
    with zipfile.ZipFile(fmu_path) as fmu:
        fmu.extractall(target)
    return target


@pytest.fixture(scope="module")
def masters(fmi_headers, tmp_path_factory):
    """The C master for linux64 (gcc) and for win64 (mingw-w64, static, C99 printf)."""
    out = tmp_path_factory.mktemp("masters")
    linux, windows = out / "master", out / "master.exe"
    run([require("gcc"), *C_FLAGS, f"-I{fmi_headers}", *C_SOURCES, "-o", linux, "-ldl", "-lm"])
    run(
        [
            require(MINGW_GCC),
            *C_FLAGS,
            "-D__USE_MINGW_ANSI_STDIO=1",
            f"-I{fmi_headers}",
            *C_SOURCES,
            "-o",
            windows,
            "-static",
        ]
    )
    return linux, windows


def read_values(text):
    lines = text.strip().splitlines()
    assert lines[0] == "time,current,voltage,power,h2Flow,energy,h2Produced"
    return np.array([[float(x) for x in line.split(",")] for line in lines[1:]])


def assert_bit_identical(a, b, what):
    assert a.shape == b.shape, what
    differ = a.view(np.uint64) != b.view(np.uint64)
    assert not differ.any(), f"{what}: {differ.sum()} values differ, first at row {np.argwhere(differ)[0]}"


# ------------------------------------------------------------------------------ the binaries


@pytest.mark.parametrize("binary", ["the FMU's library", "aem-run", "aem-identify", "aem_drive"])
def test_the_linux_binary_needs_glibc_2_17_at_most(fmu_dir, binary):
    path = {"aem-run": RUN_LINUX64, "aem-identify": IDENTIFY_LINUX, "aem_drive": DRIVE_LINUX64}.get(
        binary, fmu_dir / "binaries" / "linux64" / f"{MODEL}.so"
    )
    if not path.is_file():
        pytest.fail(f"{path} not found: scripts/test.sh builds it (packaging/platforms.py aem-run)")
    symbols = run([require("objdump"), "-T", path])
    versions = {tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", symbols)}
    assert versions, "no versioned glibc symbol: is this the right file?"
    assert max(versions) <= (2, 17), f"needs glibc {'.'.join(map(str, max(versions)))}"


def test_the_windows_dll_exports_the_34_functions_and_imports_only_system_dlls(fmu_dir):
    dump = run([require(MINGW_OBJDUMP), "-p", fmu_dir / "binaries" / "win64" / f"{MODEL}.dll"])
    exports = sorted(re.findall(r"\]\s+(fmi2\w+)", dump))
    header = (ROOT / "tests" / "c_master" / "fmu.h").read_text()
    listed = re.search(r"#define FMI2_CS_FUNCTIONS\(X\)(.*?)\n\n", header, re.S).group(1)
    assert exports == sorted(f"fmi2{name}" for name in re.findall(r"X\((\w+)\)", listed))
    assert len(exports) == 34
    imports = {name.lower() for name in re.findall(r"DLL Name: (\S+)", dump)}
    assert imports <= SYSTEM_DLLS, f"imports beyond Windows itself: {imports - SYSTEM_DLLS}"


# ------------------------------------------------------------------------------ under Wine


def test_the_windows_dll_needs_only_what_windows_has(masters, fmu_dir, wine):
    """Without the stand-in for bcryptprimitives.dll (which Wine 8.0 lacks), loading fails:
    the tests really load the DLL, and it imports nothing else that Wine lacks."""
    done = wine(masters[1], "--fmu-dir", fmu_dir, "--bad-calls", "table", shim_on_path=False, check=False)
    assert done.returncode != 0 and b"LoadLibrary" in done.stderr


def test_windows_and_linux_give_the_same_bits(masters, fmu_dir, wine, tmp_path):
    args = ["--schedule", SCHEDULE, "--step", "0.5", "--stop", "1500"]
    run([masters[0], "--fmu-dir", fmu_dir, *args, "--out", tmp_path / "linux.csv"])
    wine(masters[1], "--fmu-dir", fmu_dir, *args, "--out", tmp_path / "windows.csv")
    linux = read_values((tmp_path / "linux.csv").read_text())
    windows = read_values((tmp_path / "windows.csv").read_text().replace("\r\n", "\n"))
    assert linux.shape == (3001, 7)
    assert_bit_identical(windows, linux, "win64 vs linux64")


def test_the_stepping_library_gives_the_masters_own_bits_on_both_platforms(masters, fmu_dir, wine, tmp_path):
    """The C master through the schedule with its own loop, and with the Python package's native
    loop (aem_drive_series) of each platform's release build: every value the same bits."""
    for path in (DRIVE_LINUX64, DRIVE_DLL):
        if not path.is_file():
            pytest.fail(f"{path} not found: scripts/test.sh builds it (packaging/platforms.py all)")
    args = ["--schedule", SCHEDULE, "--step", "0.5", "--stop", "1500"]
    run([masters[0], "--fmu-dir", fmu_dir, *args, "--out", tmp_path / "own.csv"])
    run([masters[0], "--fmu-dir", fmu_dir, *args, "--out", tmp_path / "linux.csv", "--drive", DRIVE_LINUX64])
    wine(masters[1], "--fmu-dir", fmu_dir, *args, "--out", tmp_path / "windows.csv", "--drive", DRIVE_DLL)
    own = read_values((tmp_path / "own.csv").read_text())
    assert own.shape == (3001, 7)
    assert_bit_identical(read_values((tmp_path / "linux.csv").read_text()), own, "aem_drive on linux64")
    windows = read_values((tmp_path / "windows.csv").read_text().replace("\r\n", "\n"))
    assert_bit_identical(windows, own, "aem_drive.dll under Wine")


def test_the_stepping_dll_exports_its_loop_and_imports_only_system_dlls():
    dump = run([require(MINGW_OBJDUMP), "-p", DRIVE_DLL])
    assert re.findall(r"\]\s+(aem_\w+)", dump) == ["aem_drive_series"]
    imports = {name.lower() for name in re.findall(r"DLL Name: (\S+)", dump)}
    assert imports <= SYSTEM_DLLS, f"imports beyond Windows itself: {imports - SYSTEM_DLLS}"


def test_memory_cycles_on_windows_log_what_they_log_on_linux(masters, fmu_dir, wine):
    linux = run([masters[0], "--fmu-dir", fmu_dir, "--cycles", "500"])
    windows = wine(masters[1], "--fmu-dir", fmu_dir, "--cycles", "500")
    assert windows.strip() == linux.strip()
    assert linux.startswith("cycles: 500, log messages:")


def test_every_bad_call_gets_the_documented_answer_on_both_platforms(masters, fmu_dir, wine):
    linux = run([masters[0], "--fmu-dir", fmu_dir, "--bad-calls", "table"])
    windows = wine(masters[1], "--fmu-dir", fmu_dir, "--bad-calls", "table")
    assert windows == linux
    documented = set((ROOT / "docs" / "robustness.md").read_text().splitlines())
    rows = linux.strip().splitlines()[2:]
    undocumented = [row for row in rows if row not in documented]
    assert not undocumented, undocumented
    assert len(rows) >= 55


def test_windows_paths_and_file_uris_find_the_module_parameter_file(masters, fmu_dir, wine, tmp_path):
    """moduleParameterFile with a drive letter and backslashes, as a file URI with and without
    a host, and relative (found in the resources folder, whose fmuResourceLocation the master
    passes percent-encoded, with and without the host part): all give the Linux run's bits."""
    modules = [
        {"module": f"M{k}", "parameters": {"gain": {"value": g, "unit": "A/%", "source": "identified"}}}
        for k, g in enumerate([0.50, 0.56, 0.53])
    ]
    text = json.dumps({"generator": "test", "modules": modules})
    params = tmp_path / "modules dir" / "params.json"
    params.parent.mkdir()
    params.write_text(text)
    resources = fmu_dir / "resources"
    resources.mkdir(exist_ok=True)
    (resources / "modules.json").write_text(text)
    args = ["--schedule", SCHEDULE, "--step", "1", "--stop", "1500", "--modules", "6"]
    out = tmp_path / "out.csv"
    run([masters[0], "--fmu-dir", fmu_dir, *args, "--out", out])
    without_file = read_values(out.read_text())
    run([masters[0], "--fmu-dir", fmu_dir, *args, "--out", out, "--parameter-file", params])
    linux = read_values(out.read_text())
    assert not np.array_equal(linux, without_file), "the file's gains are used"

    win_params = windows_path(params)  # Z:\...\modules dir\params.json
    win_resources = windows_path(resources).replace("\\", "/")  # Z:/.../fmu dir/resources
    encoded = win_resources.replace(" ", "%20")
    forms = [
        ["--parameter-file", win_params],
        ["--parameter-file", "file:///" + windows_path(params).replace("\\", "/").replace(" ", "%20")],
        ["--parameter-file", "file://localhost/" + windows_path(params).replace("\\", "/").replace(" ", "%20")],
        ["--parameter-file", "modules.json"],  # the master's own URI: file:///Z:/...%20.../resources
        ["--parameter-file", "modules.json", "--resource-uri", "file://localhost/" + encoded],
        ["--parameter-file", "modules.json", "--resource-uri", "file:/" + encoded],
    ]
    assert "\\" in win_params and win_params.startswith("Z:\\")
    for form in forms:
        wine(masters[1], "--fmu-dir", fmu_dir, *args, "--out", out, *form)
        assert_bit_identical(read_values(out.read_text().replace("\r\n", "\n")), linux, f"win64 with {form}")


def identified(params_file):
    """{module: {parameter: value}} of a parameter file."""
    data = json.loads(Path(params_file).read_text())
    return {m["module"]: {k: v["value"] for k, v in m["parameters"].items()} for m in data["modules"]}


def test_aem_identify_exe_identifies_what_the_linux_build_does(wine, tmp_path):
    for tool in (IDENTIFY_EXE, IDENTIFY_LINUX):
        if not tool.is_file():
            pytest.fail(f"{tool} not found: scripts/test.sh builds it (packaging/platforms.py aem-identify)")
    data, held = tmp_path / "data", tmp_path / "held"
    run([IDENTIFY_LINUX, "synthesize", data, "--days", "3", "--broken"])
    run([IDENTIFY_LINUX, "synthesize", held, "--days", "1", "--skip", "3"])
    # The same files with Windows line ends.
    crlf = tmp_path / "crlf"
    crlf.mkdir()
    for f in sorted(data.glob("*.csv")):
        (crlf / f.name).write_bytes(f.read_bytes().replace(b"\n", b"\r\n"))
    assert b"\r\n" in next(crlf.glob("*.csv")).read_bytes()

    # The Windows build reads the Windows line ends; the Linux build both (one Wine run less).
    run([IDENTIFY_LINUX, "fit", data, "-o", tmp_path / "linux.json"])
    run([IDENTIFY_LINUX, "fit", crlf, "-o", tmp_path / "linux_crlf.json"])
    wine(IDENTIFY_EXE, "fit", windows_path(crlf), "-o", windows_path(tmp_path / "windows.json"))
    linux = identified(tmp_path / "linux.json")
    for name in ("linux_crlf.json", "windows.json"):
        other = identified(tmp_path / name)
        assert other.keys() == linux.keys()
        for module, values in linux.items():
            for parameter, value in values.items():
                assert other[module][parameter] == pytest.approx(value, rel=1e-9, abs=0), f"{name}: {parameter}"

    report_linux = run([IDENTIFY_LINUX, "validate", tmp_path / "linux.json", held])
    report_windows = wine(IDENTIFY_EXE, "validate", windows_path(tmp_path / "windows.json"), windows_path(held))
    # The same report but for the first line, which names the files.
    assert "RMSE current" in report_linux
    assert report_windows.strip().splitlines()[1:] == report_linux.strip().splitlines()[1:]


def test_aem_run_exe_drives_the_fmu_to_the_kpis_of_the_linux_build(wine, fmu_path, tmp_path):
    """aem-study's native master on a Windows worker: the same KPIs, bit for bit, as the glibc
    2.17 build that aem-study ships to Linux workers (and the Linux wheel carries)."""
    for tool in (RUN_EXE, RUN_LINUX64):
        if not tool.is_file():
            pytest.fail(f"{tool} not found: scripts/test.sh builds it (packaging/platforms.py aem-run)")
    rng = np.random.default_rng(5)
    reference = tmp_path / "reference.f64"
    np.clip(30e6 + np.cumsum(rng.normal(0, 3e5, 3600)), 0, 70e6).astype("<f8").tofile(reference)
    args = [
        "--step",
        "1",
        "--param",
        "dispatch=2",
        "--param",
        "belowMinimum=1",
        "--hub-size",
        "0.8",
        "--source-rating",
        "64e6",
    ]
    linux = json.loads(run([RUN_LINUX64, "--fmu", fmu_path, "--reference", reference, *args]))
    windows = json.loads(wine(RUN_EXE, "--fmu", windows_path(fmu_path), "--reference", windows_path(reference), *args))
    assert linux["status"] == "done" and linux["kpis"]["starts per module [1]"] > 0, linux
    assert windows["kpis"] == linux["kpis"]
