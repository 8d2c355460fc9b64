"""What every Python command of the package does on the command line (standard library only):

- `quiet_on_closed_stdout(main)`: a reader that goes away (`python x.py | head`) ends the command
  quietly with status 0 (the commands write their result files before their report);
- `writable(path)`, `writable_folder(folder)`: an output path is checked before the work begins;
  if it cannot be written the command ends at once (status 1) with one line naming it;
- `add_fmu_option(parser)` and `resolve_fmu(parser, args)`: `--fmu`, by default the installed package's
  FMU (aem_electrolyser.fmu_path); a missing file is a usage error naming it (status 2).
"""
import os
import sys
import tempfile
from pathlib import Path

from aem_electrolyser.locate import NotBuilt, fmu_path


def _refuse(path, error):
    where = "" if error.filename in (None, str(path)) else f" ({error.filename})"
    sys.exit(f"{Path(sys.argv[0]).name}: cannot write {path}: {error.strerror}{where}")


def writable(path):
    """`path` once its folder exists and it opens for writing; a file made only for this check is
    removed again."""
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
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as e:
        _refuse(folder, e)
    return folder


def quiet_on_closed_stdout(main):
    """Runs main(). As in Python's documentation (signal, "Note on SIGPIPE"), a closed stdout then
    points at os.devnull, so that the interpreter's last flush does not complain."""
    try:
        main()
    except BrokenPipeError:
        pass  # the result files are written before the report
    finally:
        try:
            sys.stdout.flush()
        except BrokenPipeError:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def add_fmu_option(parser):
    """Adds --fmu (default: the FMU of this installation, or the environment variable AEM_FMU)."""
    parser.add_argument("--fmu", type=Path, default=None,
                        help="the FMU [default: the one installed with this package; AEM_FMU overrides]")


def resolve_fmu(parser, args):
    """The FMU that --fmu names (or the default), or a usage error (status 2) naming the file."""
    try:
        return fmu_path(args.fmu)
    except NotBuilt as e:
        parser.error(f"--fmu: {e}")
