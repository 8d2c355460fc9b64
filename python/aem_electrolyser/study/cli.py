"""aem-study: runs every scenario of a study file on the packaged FMU and reports its KPIs.

    aem-study STUDY.toml [--out FOLDER] [--workers N | --scheduler tcp://HOST:8786 | --serial]
              [--runner PATH] [--retry-failed] [--no-plots] [--list] [--quiet] [--debug]
    aem-study --example [NAME] [--out FILE]     # the examples, or one written as a study file

By default the scenarios run on a Dask LocalCluster with one single-threaded worker process
per core; --scheduler uses an existing Dask cluster (`dask scheduler`, `dask worker`,
dask-jobqueue); --serial runs them in this process. Each finished scenario is stored in
FOLDER/scenarios/ under the key of its full definition (default FOLDER: out/<study name>):
running the study again runs only what is missing. Then FOLDER/kpis.parquet, kpis.csv,
plots/*.png and summary.txt (printed unless --quiet).

The arguments and the whole study file are checked before anything runs. Exit status 0 when
every scenario is done; 1 when some failed or were lost, or the run itself failed (one line;
--debug shows the traceback); 2 when an argument or the study file is wrong (one line); 130
when stopped with Ctrl-C (what finished is kept)."""

# This module imports no part of the [study] extra (Dask, pandas, pyarrow, matplotlib) until a
# study runs: --help, --version and --example answer without it (needs_extra).

import argparse
import sys
from pathlib import Path

from aem_electrolyser import __version__
from aem_electrolyser.cli import (
    CommandLine,
    UsageError,
    did_you_mean,
    one_line,
    positive,
    run_command,
    say,
    writable_folder,
)

from .definition import Study, StudyError

#: The example studies shipped with the package (aem-study --example NAME writes one).
EXAMPLES = Path(__file__).resolve().parent / "examples"
#: Options answered without the [study] extra (aem_electrolyser.commands.study).
WITHOUT_EXTRA = ("-h", "--help", "--version", "--example")


def needs_extra(argv):
    """Whether the command line `argv` runs (or lists) a study, which needs the [study] extra;
    --help, --version and --example do not."""
    return not any(a in WITHOUT_EXTRA or a.startswith("--example=") for a in argv)


def examples():
    """{name: path} of the example studies shipped with the package."""
    return {p.stem: p for p in sorted(EXAMPLES.glob("*.toml"))}


def runner_file(text):
    """The type of --runner: an existing file that is a program (a native executable of Linux
    or Windows, or a script), checked before any cluster starts."""
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no file {text}" + (" (a folder)" if path.is_dir() else ""))
    try:
        with open(path, "rb") as f:
            head = f.read(4)
    except OSError as e:
        raise argparse.ArgumentTypeError(f"cannot read {text} ({e.strerror})") from None
    if not head.startswith((b"\x7fELF", b"MZ", b"#!")):
        raise argparse.ArgumentTypeError(
            f"{text} is not a program (aem-run: a Linux or Windows executable, or a script that runs it)"
        )
    return path


def parser():
    """The command line of aem-study."""
    line = CommandLine(prog="aem-study", description=__doc__)
    line.add_argument("study", type=Path, nargs="?", metavar="STUDY.toml", help="the study file (TOML)")
    line.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}", help="show the version and exit"
    )
    line.add_argument(
        "--out",
        type=Path,
        metavar="FOLDER",
        help="folder for the stored scenarios and the report [default: out/<study name>]; "
        "with --example, the file (or folder) to write [default: NAME.toml here]",
    )
    line.add_argument(
        "--example",
        nargs="?",
        const="",
        metavar="NAME",
        help="write the example study NAME as a study file to start from; without NAME, list the examples",
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
        type=runner_file,
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
    line = parser()
    args = line.parse_args(argv)
    if args.example is not None:
        if args.study is not None:
            raise UsageError(f"--example writes a study file: give no STUDY.toml with it (not {args.study})")
        return _example(args)
    if args.study is None:
        line.error("give the study file STUDY.toml (or --example to start from one)")
    if args.scheduler is not None and not args.scheduler.strip():
        raise UsageError("--scheduler: give the scheduler's address, e.g. tcp://HOST:8786")
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
    say(args, f"wrote {out}/: " + ", ".join(sorted(written)))  # names relative to it: plots/<KPI>.png
    lost = len(scenarios) - len(frame)
    if lost:
        print(
            f"aem-study: {lost} scenario(s) lost with their workers (Dask gave up on them): run again to run them",
            file=sys.stderr,
        )
    return 0 if (frame["status"] == "done").all() and not lost else 1


def _example(args):
    """--example: the examples listed (no NAME), or example NAME written to --out."""
    found = examples()
    if not args.example:
        width = max(map(len, found))
        for name, path in found.items():
            print(f"{name:{width}s}  {_about(path)}")
        return 0
    if args.example not in found:
        raise UsageError(
            f"--example: no example {args.example!r}{did_you_mean(args.example, found)}; examples: {', '.join(found)}"
        )
    target = args.out or Path(f"{args.example}.toml")
    if target.is_dir():
        target = target / f"{args.example}.toml"
    if target.exists():
        raise UsageError(f"{'--out: ' if args.out else ''}{target} exists: remove it or name another file with --out")
    writable_folder(target.parent)
    target.write_text(found[args.example].read_text(encoding="utf-8"), encoding="utf-8")
    say(args, f"wrote {target}: run it with aem-study {target}")
    return 0


def _about(path):
    """The first paragraph of an example's opening comment, as one line."""
    words = []
    for line in path.read_text(encoding="utf-8").splitlines():
        text = line.removeprefix("#").strip()
        if not line.startswith("#") or not text:
            break
        words.append(text)
    return " ".join(words)


def _list(study, out):
    from .store import Store

    store = Store(out, create=False)
    for s in study.scenarios():
        record = store.get(s.key)
        state = record["status"] if record else "to run"
        print(f"{s.key}  {state:7s}  " + ", ".join(f"{k}={v}" for k, v in s.labels.items() if v is not None))
    return 0
