"""The one command-line convention of every Python command of the package.

    parser = cli.CommandLine(description=__doc__)         # adds --quiet and --debug
    parser.add_argument("--modules", type=cli.positive(int), default=25_000)
    parser.add_argument("--dispatch", type=cli.one_of(("equal", "sequential")), default="equal")
    cli.add_fmu_option(parser)
    cli.add_out_option(parser, Path("out") / "step_schedule")
    cli.run_command(main)                                  # in `if __name__ == "__main__":`

- A bad argument is refused before any work, with one line naming the option, the value and what
  is allowed ("did you mean ..." where a near name exists), exit status 2.
- A failure during the work is one line in the FMU's or the library's own words, exit status 1;
  `--debug` shows the traceback instead.
- `--out` is always a folder; `--fmu` defaults to the FMU of this installation (locate.fmu_path).
- `progress(...)` is a tqdm bar on stderr, off with `--quiet` or when stdout is not a terminal.
- A reader that goes away (`... | head`) ends the command quietly with status 0.
"""

import argparse
import difflib
import os
import re
import sys
import tempfile
from pathlib import Path

from aem_electrolyser.locate import FMU_VARIABLE, NotBuilt, fmu_from_environment, fmu_path, fmu_problem


def program_name():
    """`python -m NAME` when the program is a module of this package, else the script's name."""
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if spec is not None and spec.name.startswith("aem_electrolyser."):
        return f"python -m {spec.name.removesuffix('.__main__')}"
    return Path(sys.argv[0]).name


def nearest(value, allowed):
    """The name of `allowed` nearest to `value` (as text), or None when none is near."""
    near = difflib.get_close_matches(str(value), [str(a) for a in allowed], n=1, cutoff=0.6)
    return near[0] if near else None


def did_you_mean(value, allowed):
    """' (did you mean X?)' for the nearest of `allowed`, or ''."""
    near = nearest(value, allowed)
    return f" (did you mean {near!r}?)" if near else ""


class UsageError(Exception):
    """A bad argument found after parsing (e.g. in a study file): main() raises it, run_command
    prints it as a usage error (status 2)."""


class CommandLine(argparse.ArgumentParser):
    """argparse with the package's conventions: options are not abbreviated, --quiet and --debug
    exist, and an error is one line with a suggestion where a near name exists (status 2)."""

    def __init__(self, prog=None, description=None, quiet=True, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(prog=prog or program_name(), description=description, **kwargs)
        if quiet:
            self.add_argument("--quiet", action="store_true", help="no progress bar and no report on the terminal")
        self.add_argument("--debug", action="store_true", help="show the traceback of a failure")

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {self._suggest(message)}\n")

    def _suggest(self, message):
        choice = re.match(r"argument (\S+): invalid choice: '([^']*)' \(choose from (.*)\)$", message)
        if choice:
            option, value, allowed = choice.groups()
            names = [a.strip().strip("'") for a in allowed.split(",")]
            return f"{option}: {value!r} is not one of {', '.join(names)}{did_you_mean(value, names)}"
        unknown = re.match(r"unrecognized arguments: (.*)$", message)
        if unknown:  # suggested among the options --help shows (not the old spellings kept hidden)
            options = [o for a in self._actions if a.help != argparse.SUPPRESS for o in a.option_strings]
            first = unknown.group(1).split()[0]
            return f"unknown option {first}{did_you_mean(first.split('=')[0], options)}; see --help"
        return message


# --- argument types: each refuses a bad value with a message that names what is allowed ---------


def positive(kind=float):
    """A type for numbers > 0 (int or float)."""

    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'}") from None
        if not value > 0 or value != value or value in (float("inf"),):
            raise argparse.ArgumentTypeError(f"must be a positive {'integer' if kind is int else 'number'}, not {text}")
        return value

    parse.__name__ = f"positive {kind.__name__}"
    return parse


def non_negative(kind=float):
    """A type for finite numbers ≥ 0."""

    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not 0 <= value < float("inf"):
            raise argparse.ArgumentTypeError(f"must be zero or more, not {text}")
        return value

    return parse


def one_of(allowed):
    """A type for one name of `allowed` (a suggestion for a near miss)."""

    def parse(text):
        if text not in allowed:
            raise argparse.ArgumentTypeError(
                f"{text!r} is not one of {', '.join(allowed)}{did_you_mean(text, allowed)}"
            )
        return text

    return parse


def list_of(allowed):
    """A type for comma-separated names of `allowed` (a list, order kept, no repeats), in any
    case ('fcr-d up' is 'FCR-D up'); 'all' stands for every one."""
    spelled = {str(a).casefold(): a for a in allowed}

    def parse(text):
        if text.strip().casefold() == "all":
            return list(allowed)
        names = [n.strip() for n in text.split(",") if n.strip()]
        if not names:
            raise argparse.ArgumentTypeError(f"name at least one of {', '.join(allowed)}")
        for n in names:
            if n.casefold() not in spelled:
                near = nearest(n.casefold(), spelled)
                hint = f" (did you mean {spelled[near]!r}?)" if near else ""  # in the names' own spelling
                raise argparse.ArgumentTypeError(f"{n!r} is not one of {', '.join(allowed)}{hint}")
        return list(dict.fromkeys(spelled[n.casefold()] for n in names))

    return parse


# --- the FMU and the output folder -----------------------------------------------------------


def add_fmu_option(parser):
    """Adds --fmu (default: the FMU of this installation, or the environment variable AEM_FMU)."""
    parser.add_argument(
        "--fmu",
        type=Path,
        default=None,
        help="the FMU [default: the one installed with this package; AEM_FMU overrides]",
    )


def resolve_fmu(parser, args):
    """The FMU that --fmu names (or the default), or a usage error (status 2): the file is
    missing, or it is not an FMU (a zip archive with a modelDescription.xml). An FMU that the
    environment variable AEM_FMU names is blamed on AEM_FMU, not on --fmu."""
    from_environment = fmu_from_environment(args.fmu)
    try:
        path = fmu_path(args.fmu)
    except NotBuilt as e:
        parser.error(str(e) if from_environment else f"--fmu: {e}")
    problem = fmu_problem(path)
    if problem:
        parser.error(f"{FMU_VARIABLE if from_environment else '--fmu'}: {path} {problem}")
    return path


def add_out_option(parser, default, what="the result files"):
    """Adds --out, a folder (made if missing)."""
    parser.add_argument(
        "--out", type=Path, default=Path(default), metavar="FOLDER", help=f"folder for {what} [default: {default}]"
    )


def add_version_option(parser):
    """Adds --version: the program's name and the package's version (the Cargo workspace's)."""
    from aem_electrolyser import __version__

    parser.add_argument(
        "--version", action="version", version=f"{parser.prog} {__version__}", help="show the version and exit"
    )


def add_old_spelling(parser, action, old):
    """Accepts `old` as a spelling of the option `action` (what add_argument returned) that an
    earlier version had: the same destination and value, not shown by --help nor suggested."""
    kwargs = {"dest": action.dest, "default": argparse.SUPPRESS, "help": argparse.SUPPRESS}
    if action.nargs != 0:  # an option with a value
        kwargs.update(type=action.type, nargs=action.nargs, choices=action.choices, metavar=action.metavar)
    parser.add_argument(old, action=type(action), **kwargs)


def _refuse(path, error):
    where = "" if error.filename in (None, str(path)) else f" ({error.filename})"
    sys.exit(f"{program_name()}: error: cannot write {path}: {error.strerror}{where}")


def writable(path):
    """`path` once its folder exists and it opens for writing; a file made only for this check is
    removed again. Otherwise the command ends (status 1) with one line naming it."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        existed = path.exists()
        open(path, "a").close()
        if not existed:
            path.unlink()
    except OSError as e:
        _refuse(path, e)
    return path


def writable_folder(folder):
    """`folder` once it exists and takes a new file (made and removed again)."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():  # a bad argument, as aem-study's check says too
        print(f"{program_name()}: error: --out: {folder} is a file; --out names a folder", file=sys.stderr)
        sys.exit(2)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as e:
        _refuse(folder, e)
    return folder


# --- running and reporting -------------------------------------------------------------------


def one_line(error):
    """An exception as one line in its own words (its type where the words are not enough)."""
    text = " ".join(str(error).split())
    if isinstance(error, (KeyError, IndexError)) or not text:
        text = f"{type(error).__name__}: {text}" if text else type(error).__name__
    return text


def run_command(main, argv=None):
    """Runs main(argv) as a command: its return value is the exit status; an exception is one
    line on stderr and status 1 (the traceback with --debug); UsageError is status 2;
    Ctrl-C is status 130; a closed stdout ends it quietly."""
    arguments = sys.argv[1:] if argv is None else argv
    debug = "--debug" in arguments
    try:
        status = main(argv)
    except BrokenPipeError:
        status = 0  # the result files are written before the report
    except KeyboardInterrupt:
        print(f"{program_name()}: interrupted", file=sys.stderr)
        status = 130
    except UsageError as e:
        print(f"{program_name()}: error: {e}", file=sys.stderr)
        status = 2
    except Exception as e:  # noqa: BLE001 - every failure becomes one line unless --debug
        if debug:
            raise
        print(f"{program_name()}: error: {one_line(e)} (--debug shows the traceback)", file=sys.stderr)
        status = 1
    finally:
        try:
            sys.stdout.flush()
        except BrokenPipeError:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    sys.exit(status or 0)


def quiet_on_closed_stdout(main):
    """Runs main() (no arguments) with run_command's handling."""
    run_command(lambda argv: main())


def shows_progress(quiet=False):
    """A progress bar is drawn unless --quiet or stdout is not a terminal (a log, a pipe)."""
    return not quiet and sys.stdout.isatty()


def progress(iterable=None, total=None, desc=None, unit="it", quiet=False, **kwargs):
    """A tqdm bar on stderr (see shows_progress); usable as an iterable wrapper or with update()."""
    from tqdm import tqdm

    return tqdm(
        iterable,
        total=total,
        desc=desc,
        unit=unit,
        file=sys.stderr,
        dynamic_ncols=True,
        disable=not shows_progress(quiet),
        leave=False,
        **kwargs,
    )


def say(args, *text):
    """print(*text) unless --quiet."""
    if not getattr(args, "quiet", False):
        print(*text, flush=True)
