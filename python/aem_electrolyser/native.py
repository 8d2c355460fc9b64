"""The entry points `aem-identify` and `aem-run`: they run the native command of this
installation (aem_electrolyser.locate.binary) with the same arguments and exit status."""

import os
import subprocess
import sys

from .locate import FMU_VARIABLE, NotBuilt, binary, fmu_from_environment, fmu_path, fmu_problem


def _run(name, defaults=()):
    """Runs the native command `name`; `defaults` are (option, value function) pairs added when
    the option is not given (and neither --help nor --version is asked for). A value function's
    NotBuilt is one line, blamed on the option (status 1), or on AEM_FMU when the value came from
    it (status 2, as for a bad --fmu)."""
    try:
        path = binary(name)
    except NotBuilt as e:
        sys.exit(f"{name}: error: {e}")
    arguments = sys.argv[1:]
    if not {"-h", "--help", "-V", "--version"} & set(arguments):
        for option, value in defaults:
            if option not in arguments:
                try:
                    arguments = [option, str(value()), *arguments]
                except NotBuilt as e:
                    if str(e).startswith(f"{FMU_VARIABLE}:"):  # a bad setting, as a bad --fmu is
                        print(f"{name}: error: {e}", file=sys.stderr)
                        sys.exit(2)
                    sys.exit(f"{name}: error: {option}: {e}")
    argv = [str(path), *arguments]
    if os.name == "nt":  # no exec on Windows: wait for the child and pass its status on
        sys.exit(subprocess.call(argv))
    os.execv(argv[0], argv)


def identify():
    """aem-identify: synthesize, fit, validate (the Rust command)."""
    _run("aem-identify")


def _default_fmu():
    """The FMU of this installation, or AEM_FMU's, for aem-run's --fmu; one that AEM_FMU names
    is checked here, so that its error names AEM_FMU rather than --fmu."""
    path = fmu_path()
    problem = fmu_problem(path) if fmu_from_environment() else None
    if problem:
        raise NotBuilt(f"{FMU_VARIABLE}: {path} {problem}")
    return path


def run():
    """aem-run: the native FMI master of aem-study (the Rust command); --fmu defaults to the FMU
    of this installation (AEM_FMU overrides)."""
    _run("aem-run", defaults=[("--fmu", _default_fmu)])
