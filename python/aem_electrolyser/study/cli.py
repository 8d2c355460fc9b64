"""aem-study: runs every scenario of a study file on the packaged FMU and reports its KPIs.

    aem-study STUDY.toml [--out DIR] [--workers N | --scheduler tcp://HOST:8786 | --serial]
              [--runner PATH] [--retry-failed] [--no-plots] [--list]

By default the scenarios run on a Dask LocalCluster with one single-threaded worker process
per core; --scheduler uses an existing Dask cluster (`dask scheduler`, `dask worker`,
dask-jobqueue); --serial runs them in this process. Each finished scenario is stored in
DIR/scenarios/ under the key of its full definition (default DIR: out/<study name>): running
the study again runs only what is missing. Then DIR/kpis.parquet, kpis.csv, plots/*.png and
summary.txt (printed). Exit status 0 when every scenario is done, 1 when some failed or were
lost, 2 when the study file is wrong."""
import argparse
import sys
from pathlib import Path

from . import engine
from .definition import Study
from .report import write_report
from .table import table

from aem_electrolyser.cli import quiet_on_closed_stdout, writable_folder


def main(argv=None):
    """The command: its exit status (a reader that goes away ends it quietly, results written)."""
    status = 0

    def run():
        nonlocal status
        status = _main(argv)

    quiet_on_closed_stdout(run)
    return status


def _main(argv):
    parser = argparse.ArgumentParser(prog="aem-study", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("study", type=Path)
    parser.add_argument("--out", type=Path)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="LocalCluster worker processes (default: one per core)")
    where.add_argument("--scheduler", help="address of an existing Dask scheduler, e.g. tcp://HOST:8786")
    where.add_argument("--serial", action="store_true", help="run in this process, no Dask")
    parser.add_argument("--runner", type=Path, help="the aem-run binary to ship to workers of this platform "
                        "(default: the installation's own)")
    parser.add_argument("--retry-failed", action="store_true", help="run failed scenarios again")
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--list", action="store_true", help="list the scenarios and whether they are stored")
    args = parser.parse_args(argv)
    try:
        study = Study(args.study)
    except (OSError, ValueError) as e:
        print(f"aem-study: {args.study}: {e}", file=sys.stderr)
        return 2
    out = args.out or Path("out") / args.study.stem
    if args.list:
        return _list(study, out)
    writable_folder(out)
    try:
        records = engine.run(study, out, scheduler=args.scheduler, workers=args.workers, serial=args.serial,
                             runner=args.runner, retry_failed=args.retry_failed)
    except KeyboardInterrupt:
        print(f"aem-study: stopped; finished scenarios are kept in {out / 'scenarios'}: run again to resume",
              file=sys.stderr)
        return 130
    except FileNotFoundError as e:
        print(f"aem-study: {e}", file=sys.stderr)
        return 2
    scenarios = study.scenarios()
    frame = table(scenarios, study.axis_columns, records)
    written = write_report(frame, study.axis_columns, out, study.title, plots=not args.no_plots)
    print(Path(written["summary.txt"]).read_text(), end="")
    print(f"wrote {out}/: " + ", ".join(sorted(Path(p).name for p in written.values())))
    lost = len(scenarios) - len(frame)
    if lost:
        print(f"aem-study: {lost} scenario(s) lost with their workers (Dask gave up on them): run again to "
              f"run them", file=sys.stderr)
    return 0 if (frame["status"] == "done").all() and not lost else 1


def _list(study, out):
    from .store import Store
    store = Store(out)
    for s in study.scenarios():
        record = store.get(s.key)
        state = record["status"] if record else "to run"
        print(f"{s.key}  {state:7s}  " + ", ".join(f"{k}={v}" for k, v in s.labels.items() if v is not None))
    return 0
