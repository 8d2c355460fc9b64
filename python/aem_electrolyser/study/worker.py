"""One scenario on a worker: the FMU, `aem-run` and the series' data come from the client
(no shared file system); the reference is built here and `aem-run` drives the FMU with it.

The same function runs a scenario serially and on a Dask worker, so a study's KPIs are the
same bit for bit either way."""

import hashlib
import json
import os
import platform
import signal
import socket
import subprocess
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .series import SeriesError, reference


class ScenarioError(ValueError):
    """A scenario that cannot run: no runner for the worker, an inconsistent definition."""


class RunnerKilled(RuntimeError):
    """aem-run ended by a signal: the scenario did not fail, it was stopped, so it has no record
    (on Dask its task fails and the client counts it lost: a rerun runs it)."""


def dask_setup(worker):
    """Dask preload hook (aem-study's LocalCluster names this module as its workers' preload):
    Ctrl-C in the terminal reaches every process of the group, and a worker is the client's to
    stop, so it ignores SIGINT instead of dying with a traceback. By a Python handler, not
    SIG_IGN, so that aem-run (a new program: caught signals reset) still stops at Ctrl-C."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, _ignore)
        if hasattr(signal, "pthread_sigmask"):  # started with it blocked (engine._client)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _ignore(signum, frame):
    pass


def this_platform():
    """The key of a runner binary that runs here, e.g. linux-x86_64."""
    return f"{platform.system().lower()}-{platform.machine().lower()}"


@dataclass(frozen=True)
class Bundle:
    """What every worker needs, sent once per worker: the FMU, aem-run per platform, the
    files String parameters name (by sha256) and the file series (sha256 -> (times, values))."""

    fmu: bytes
    runners: dict
    files: dict
    series: dict


_materialised = {}


def _cache_dir():
    path = Path(tempfile.gettempdir()) / f"aem-study-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
    path.mkdir(exist_ok=True)
    return path


def _materialise(data: bytes, suffix: str, executable=False):
    """A local file with `data` (once per process; named by its hash, so a rebuilt FMU or
    runner is a new file)."""
    digest = hashlib.sha256(data).hexdigest()
    if digest not in _materialised:
        path = _cache_dir() / f"{digest[:24]}{suffix}"
        if not path.exists() or path.stat().st_size != len(data):
            partial = path.with_suffix(f".{os.getpid()}.part")
            partial.write_bytes(data)
            if executable:
                partial.chmod(0o755)
            os.replace(partial, path)
        _materialised[digest] = path
    return _materialised[digest]


def run_scenario(key: str, definition: dict, bundle: Bundle) -> dict:
    """The scenario's record: key, definition, status ("done"/"failed"), message, KPIs, the
    FMU's messages, run time and worker."""
    record = {"scenario": key, "definition": definition, "worker": f"{socket.gethostname()}:{os.getpid()}"}
    try:
        series = definition["series"]
        if series.get("error"):  # the series' own words, before anything derived from it (its span)
            raise SeriesError(series["error"])
        runner = bundle.runners.get(this_platform())
        if runner is None:
            raise ScenarioError(
                f"no aem-run for this worker's platform {this_platform()} (the client has {', '.join(bundle.runners)})"
            )
        args = [
            str(_materialise(runner, "-aem-run.exe" if os.name == "nt" else "-aem-run", executable=True)),
            "--fmu",
            str(_materialise(bundle.fmu, ".fmu")),
            "--step",
            repr(definition["step [s]"]),
            "--input",
            definition["input"],
        ]
        for name, value in definition["parameters"].items():
            if value.startswith("file:sha256:"):
                value = str(_materialise(bundle.files[value.removeprefix("file:sha256:")], ".data"))
            args += ["--param", f"{name}={value}"]
        if definition["hub size"] is not None:
            if definition["input"] != "power" or not definition["source rating [W]"]:
                raise ScenarioError("a hub size relative to the source needs a power series with a rating")
            args += [
                "--hub-size",
                repr(definition["hub size"]),
                "--source-rating",
                repr(definition["source rating [W]"]),
            ]
        step, horizon = definition["step [s]"], definition["horizon [s]"]
        steps = round(horizon / step)
        if steps < 1 or abs(steps * step - horizon) > 1e-9 * horizon:
            raise ScenarioError(f"the horizon {horizon} s is not a whole number of steps of {step} s")
        values = reference(series, step, horizon, bundle.series.get(series.get("sha256")))
        with tempfile.NamedTemporaryFile(dir=_cache_dir(), suffix=".f64", delete=False) as f:
            np.ascontiguousarray(values, dtype="<f8").tofile(f)  # no copy of a year's 252 MB
        try:
            done = subprocess.run(args + ["--reference", f.name], capture_output=True, text=True)
        finally:
            os.unlink(f.name)
        if done.returncode < 0:  # killed (Ctrl-C, a worker closing, the OOM killer): not the scenario's fault
            raise RunnerKilled(f"aem-run was killed by signal {-done.returncode}; the scenario is not stored")
        try:
            report = json.loads(done.stdout)
        except json.JSONDecodeError:
            raise ScenarioError(f"aem-run exited with {done.returncode}: {done.stderr.strip() or done.stdout.strip()}")
        if report["status"] == "done" and report.get("kpi version") != definition["kpi version"]:
            raise ScenarioError(
                f"aem-run computes KPIs of version {report.get('kpi version')}, the study expects "
                f"{definition['kpi version']}: ship the aem-run of this checkout"
            )
        record.update(
            status=report["status"],
            message=report.get("message", ""),
            kpis=report.get("kpis", {}),
            messages=report.get("messages", []),
            **({"run time [s]": report["run time [s]"]} if "run time [s]" in report else {}),
        )
    except (SeriesError, OSError, ValueError) as e:
        record.update(status="failed", message=str(e), kpis={}, messages=[])
    return record
