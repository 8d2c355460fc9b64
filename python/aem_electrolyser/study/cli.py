"""aem-study: runs every scenario of a study file on the packaged FMU and reports its KPIs.

    aem-study STUDY.toml [--out FOLDER] [--workers N | --scheduler tcp://HOST:8786 | --serial]
              [--runner PATH] [--retry-failed] [--no-plots] [--list] [--quiet] [--debug]

By default the scenarios run on a Dask LocalCluster with one single-threaded worker process
per core; --scheduler uses an existing Dask cluster (`dask scheduler`, `dask worker`,
dask-jobqueue); --serial runs them in this process. Each finished scenario is stored in
FOLDER/scenarios/ under the key of its full definition (default FOLDER: out/<study name>):
running the study again runs only what is missing. Then FOLDER/kpis.parquet, kpis.csv,
plots/*.png and summary.txt (printed unless --quiet).

The arguments and the whole study file are checked before anything runs. Exit status 0 when
every scenario is done; 1 when some failed or were lost, or the run itself failed (one line;
--debug shows the traceback); 2 when an argument or the study file is wrong (one line)."""

import sys
from pathlib import Path

from aem_electrolyser.cli import CommandLine, UsageError, one_line, positive, run_command, say, writable_folder

from .definition import Study, StudyError


def parser():
    """The command line of aem-study."""
    line = CommandLine(prog="aem-study", description=__doc__)
    line.add_argument("study", type=Path, metavar="STUDY.toml", help="the study file (TOML)")
    line.add_argument(
        "--out",
        type=Path,
        metavar="FOLDER",
        help="folder for the stored scenarios and the report [default: out/<study name>]",
    )
    where = line.add_mutually_exclusive_group()
    where.add_argument(
        "--workers", type=positive(int), metavar="N", help="LocalCluster worker processes [default: one per core]"
    )
    where.add_argument(
        "--scheduler", metavar="ADDRESS", help="address of an existing Dask scheduler, e.g. tcp://HOST:8786"
    )
    where.add_argument("--serial", action="store_true", help="run in this process, no Dask")
    line.add_argument(
        "--runner",
        type=Path,
        metavar="PATH",
        help="the aem-run binary to ship to workers of this platform [default: the installation's own]",
    )
    line.add_argument("--retry-failed", action="store_true", help="run failed scenarios again")
    line.add_argument("--no-plots", action="store_true", help="no plots/*.png")
    line.add_argument("--list", action="store_true", help="list the scenarios and whether they are stored")
    return line


def main(argv=None):
    """The command (the package's convention, aem_electrolyser.cli.run_command): returns its exit
    status. A reader that goes away (`aem-study ... | head`) ends it quietly, results written."""
    try:
        run_command(_main, argv)
    except SystemExit as e:
        if isinstance(e.code, str):  # a folder that cannot be written (cli.writable_folder)
            print(e.code, file=sys.stderr)
            return 1
        return e.code or 0
    return 0


def read_study(path):
    """The study file read and checked, or a UsageError of one line naming the file."""
    try:
        return Study(path)
    except StudyError as e:
        raise UsageError(str(e)) from None
    except (OSError, ValueError, TypeError) as e:  # not foreseen by Study's own checks
        raise UsageError(f"{path}: {one_line(e)}") from None


def _main(argv):
    args = parser().parse_args(argv)
    if args.scheduler is not None and not args.scheduler.strip():
        raise UsageError("--scheduler: give the scheduler's address, e.g. tcp://HOST:8786")
    if args.runner is not None and not args.runner.is_file():
        raise UsageError(f"--runner: no file {args.runner}")
    out = args.out or Path("out") / args.study.stem
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out: {out} is a file; --out names a folder")
    study = read_study(args.study)
    if args.list:
        return _list(study, out)
    writable_folder(out)
    # Dask, pandas and matplotlib (seconds to import) once the arguments and the study are known good.
    from . import engine
    from .report import write_report
    from .table import table

    try:
        records = engine.run(
            study,
            out,
            scheduler=args.scheduler,
            workers=args.workers,
            serial=args.serial,
            runner=args.runner,
            retry_failed=args.retry_failed,
            quiet=args.quiet,
        )
    except KeyboardInterrupt:
        print(
            f"aem-study: stopped; finished scenarios are kept in {out / 'scenarios'}: run again to resume",
            file=sys.stderr,
        )
        return 130
    scenarios = study.scenarios()
    frame = table(scenarios, study.axis_columns, records)
    written = write_report(frame, study.axis_columns, out, study.title, plots=not args.no_plots)
    if not args.quiet:
        print(Path(written["summary.txt"]).read_text(encoding="utf-8"), end="")
    say(args, f"wrote {out}/: " + ", ".join(sorted(Path(p).name for p in written.values())))
    lost = len(scenarios) - len(frame)
    if lost:
        print(
            f"aem-study: {lost} scenario(s) lost with their workers (Dask gave up on them): run again to run them",
            file=sys.stderr,
        )
    return 0 if (frame["status"] == "done").all() and not lost else 1


def _list(study, out):
    from .store import Store

    store = Store(out, create=False)
    for s in study.scenarios():
        record = store.get(s.key)
        state = record["status"] if record else "to run"
        print(f"{s.key}  {state:7s}  " + ", ".join(f"{k}={v}" for k, v in s.labels.items() if v is not None))
    return 0
