"""The entry points `aem-identify` and `aem-run`: they run the native command of this
installation (aem_electrolyser.locate.binary) with the same arguments and exit status."""
import os
import subprocess
import sys

from .locate import NotBuilt, binary


def _run(name):
    try:
        path = binary(name)
    except NotBuilt as e:
        sys.exit(f"{name}: {e}")
    argv = [str(path), *sys.argv[1:]]
    if os.name == "nt":  # no exec on Windows: wait for the child and pass its status on
        sys.exit(subprocess.call(argv))
    os.execv(argv[0], argv)


def identify():
    """aem-identify: synthesize, fit, validate (the Rust command)."""
    _run("aem-identify")


def run():
    """aem-run: the native FMI master of aem-study (the Rust command)."""
    _run("aem-run")
