"""The entry points `aem-identify` and `aem-run`: they run the native command of this
installation (aem_electrolyser.locate.binary) with the same arguments and exit status."""

import os
import subprocess
import sys

from .locate import NotBuilt, binary, fmu_path


def _run(name, defaults=()):
    """Runs the native command `name`; `defaults` are (option, value function) pairs added when
    the option is not given (and --help is not asked for)."""
    try:
        path = binary(name)
    except NotBuilt as e:
        sys.exit(f"{name}: error: {e}")
    arguments = sys.argv[1:]
    if not {"-h", "--help"} & set(arguments):
        for option, value in defaults:
            if option not in arguments:
                try:
                    arguments = [option, str(value()), *arguments]
                except NotBuilt as e:
                    sys.exit(f"{name}: error: {option}: {e}")
    argv = [str(path), *arguments]
    if os.name == "nt":  # no exec on Windows: wait for the child and pass its status on
        sys.exit(subprocess.call(argv))
    os.execv(argv[0], argv)


def identify():
    """aem-identify: synthesize, fit, validate (the Rust command)."""
    _run("aem-identify")


def run():
    """aem-run: the native FMI master of aem-study (the Rust command); --fmu defaults to the FMU
    of this installation."""
    _run("aem-run", defaults=[("--fmu", fmu_path)])
