"""Runs a study's scenarios that are not stored yet: serially in this process, on a Dask
LocalCluster (one single-threaded worker process per core) or on an existing Dask cluster.

Every scenario is one Dask task named by its key; the FMU, aem-run and the series' data go to
each worker once (scattered, broadcast); a record is stored the moment its task finishes. A
task whose worker dies is rerun by Dask on another worker; a study stopped with Ctrl-C keeps
what finished. The KPIs do not depend on where a scenario ran (same binary, same inputs)."""

import contextlib
import logging
import os
import signal
import sys
import tempfile
import zipfile
from pathlib import Path

from .. import locate
from .progress import Progress
from .store import Store
from .worker import Bundle, run_scenario, this_platform

PACKAGE = Path(__file__).resolve().parents[1]


def runners(runner=None):
    """Platform -> aem-run's bytes: `runner` for this platform if given; else the portable
    builds that exist and this machine's release build for its own platform."""
    if runner is not None:
        found = {this_platform(): Path(runner)}
    else:
        # Portable builds go to workers of every platform (glibc 2.17 runs on old Linux clusters,
        # the .exe on Windows workers); this installation's own aem-run if none is newer.
        found = locate.portable_runners()
        own = locate.binary("aem-run")
        portable = found.get(this_platform())
        if portable is None or (portable != own and portable.stat().st_mtime < own.stat().st_mtime):
            if portable is not None:
                print(
                    f"aem-study: {portable} is older than {own}: shipping the latter, which needs "
                    f"this machine's C library on the workers (rebuild: packaging/platforms.py aem-run)",
                    file=sys.stderr,
                )
            found[this_platform()] = own
    for path in found.values():
        if not path.is_file():
            raise FileNotFoundError(f"no aem-run at {path} (build it: cargo build --release -p aem-run)")
    return {name: path.read_bytes() for name, path in found.items()}


def bundle(study, runner=None):
    """What the workers need of `study`: the FMU, the runners, files and series."""
    return Bundle(
        fmu=study.fmu_bytes, runners=runners(runner), files=dict(study.files), series=study.file_series_data()
    )


def run(
    study,
    out_dir,
    *,
    scheduler=None,
    workers=None,
    serial=False,
    runner=None,
    retry_failed=False,
    stream=None,
    quiet=False,
):
    """Runs what is missing; returns {key: record} of every scenario of the study that has one.
    Progress on `stream` (stderr) unless `quiet` (study.progress)."""
    store = Store(out_dir)
    scenarios = study.scenarios()
    records = {}
    for s in scenarios:
        record = store.get(s.key)
        if record is not None and (record["status"] == "done" or not retry_failed):
            records[s.key] = record
    todo = [s for s in scenarios if s.key not in records]
    progress = Progress(len(scenarios), len(records), quiet=quiet, **({"stream": stream} if stream else {}))
    try:
        if todo:
            payload = bundle(study, runner)
            if serial:
                _run_serial(todo, payload, store, records, progress)
            else:
                _run_dask(todo, payload, store, records, progress, scheduler, workers)
    finally:
        progress.close()
    return records


def _run_serial(todo, payload, store, records, progress):
    for i, s in enumerate(todo):
        record = run_scenario(s.key, s.definition, payload)
        store.put(record)
        records[s.key] = record
        progress.finished(record, 1 if i + 1 < len(todo) else 0, s.labels)


@contextlib.contextmanager
def _client(scheduler, workers):
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler) as client:
            archive = _package_zip()
            try:
                client.upload_file(archive)
            finally:
                os.unlink(archive)
            yield client
        return
    n = workers or os.cpu_count() or 1
    cluster = client = None
    stopped = True
    try:
        # Ctrl-C in a terminal reaches every process of the group. The workers are this process's
        # to stop: they start with SIGINT blocked (inherited) and, once up, ignore it (their
        # preload, worker.dask_setup), where they would die with a traceback each. A Ctrl-C while
        # they start waits here until they are up, and is raised then.
        with _sigint_held():
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                silence_logs=logging.ERROR,
                # Dask's HTTP routes on a free port of the loopback: its default 8787 may be
                # another cluster's (a warning of four lines) and no one reads them here.
                scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                preload=["aem_electrolyser.study.worker"],
            )
            client = Client(cluster)
        yield client
        stopped = False
    finally:
        _close(client, cluster, quickly=stopped)


#: Seconds a stopped study gives its client to close.
CLOSE_TIMEOUT = 3.0


@contextlib.contextmanager
def _sigint_held():
    """A Ctrl-C (SIGINT) held back until the block ends, then raised: SIGINT is blocked in this
    thread (and so in the threads and processes it starts meanwhile, where the platform allows
    it) and one that reaches another thread is only noted."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: noted.append(signum))
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if hasattr(signal, "pthread_sigmask") else None
    try:
        yield
    finally:
        if mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # one that waited is noted now
        signal.signal(signal.SIGINT, previous)
        if noted and callable(previous):
            previous(signal.SIGINT, None)  # Python's own handler raises KeyboardInterrupt


def _close(client, cluster, quickly):
    """Closes the client and the LocalCluster. `quickly` (a study stopped or failing): no
    waiting for running scenarios, whose results would not be stored anyway: the worker
    processes and their aem-run are killed, their nannies told first not to restart them, and
    Dask's complaints about it are not shown."""
    if quickly:
        for name in ("distributed", "tornado", "asyncio"):
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    with _sigint_held():  # a second Ctrl-C does not leave the workers behind
        if client is not None:
            with contextlib.suppress(Exception):
                client.close(timeout=CLOSE_TIMEOUT if quickly else None)
        if cluster is None:
            return
        if quickly:
            with contextlib.suppress(Exception):
                _kill_workers(cluster)
        cluster.close()


def _kill_workers(cluster):
    """Kills the worker processes of a LocalCluster and (on Linux) their children, the aem-run
    they run, once their nannies know not to restart them (Nanny.close_gracefully, the signal
    Dask's own shutdown gives)."""
    nannies = list(cluster.workers.values())

    async def no_restarts():
        for nanny in nannies:
            nanny.close_gracefully()

    cluster.sync(no_restarts)
    for nanny in nannies:
        pid = nanny.pid
        if pid:
            for process in [*_children(pid), pid]:
                with contextlib.suppress(OSError):
                    os.kill(process, getattr(signal, "SIGKILL", signal.SIGTERM))


def _children(pid):
    """Every descendant process id of `pid`, from /proc (none where there is no /proc)."""
    found, todo = [], [pid]
    while todo:
        parent = todo.pop()
        try:
            tasks = os.listdir(f"/proc/{parent}/task")
        except OSError:
            continue
        for task in tasks:
            try:
                with open(f"/proc/{parent}/task/{task}/children") as f:
                    kids = [int(k) for k in f.read().split()]
            except OSError:
                continue
            found = kids + found
            todo += kids
    return found


def _package_zip():
    """The aem_electrolyser package's Python modules as a zip Dask sends to the workers of an
    existing cluster, which need not have it installed (they need its core dependencies and
    the [study] extra's)."""
    handle, archive = tempfile.mkstemp(prefix="aem-electrolyser-", suffix=".zip")
    with os.fdopen(handle, "wb") as f, zipfile.ZipFile(f, "w") as z:
        for file in sorted(PACKAGE.rglob("*.py")):
            z.write(file, f"aem_electrolyser/{file.relative_to(PACKAGE).as_posix()}")
    return archive


def _run_dask(todo, payload, store, records, progress, scheduler, workers):
    from distributed import as_completed

    labels = {s.key: s.labels for s in todo}
    with _client(scheduler, workers) as client:
        threads = sum(client.nthreads().values())
        shared = client.scatter(payload, broadcast=True, hash=False)
        futures = [
            client.submit(run_scenario, s.key, s.definition, shared, key=f"aem-study-{s.key}", pure=False) for s in todo
        ]
        pending = len(futures)
        try:
            for future in as_completed(futures):
                pending -= 1
                key = future.key.removeprefix("aem-study-")
                try:
                    record = future.result()
                except Exception as e:  # the task's worker died too often: not the scenario's fault
                    record = {"scenario": key, "status": "lost", "message": f"{type(e).__name__}: {e}"}
                    progress.finished(record, min(pending, threads), labels[key])
                    continue
                store.put(record)
                records[key] = record
                progress.finished(record, min(pending, threads), labels[key])
        except KeyboardInterrupt:
            client.cancel(futures)
            raise
