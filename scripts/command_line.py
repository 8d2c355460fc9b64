"""What every Python command of the project does on the command line (imported by the commands in
examples/, packaging/ and scripts/; standard library only):

- `quiet_on_closed_stdout(main)`: a reader that goes away (`python x.py | head`) ends the command
  quietly with status 0 (the commands write their result files before their report);
- `writable(path)`, `writable_folder(folder)`: an output path is checked before the work begins;
  if it cannot be written the command ends at once (status 1) with one line naming it.
"""
import os
import sys
import tempfile
from pathlib import Path


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
