"""Runs the repository's commands as a new user meets them, for the tests of command-line
hygiene (cli/test_closed_stdout.py) and of the frameworks' commands (cosim/test_mosaik.py)."""

import os
import subprocess
import sys

from conftest import ROOT


def run(args, stdout_closed=True, timeout=120, env=None, buffered=False):
    """Runs a command of the repository. With stdout_closed its stdout is a pipe whose reading
    end is closed before the command starts (as `| head` leaves it once it has its lines);
    closing it before the start rather than after makes the test independent of timing.
    Unbuffered (the default here), every print meets the closed pipe at once, so a print before
    the result files are written shows as missing files; buffered, the pipe is met at the end."""
    env = {**os.environ, **(env or {}), "PYTHONUNBUFFERED": "" if buffered else "1"}
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run(
            [sys.executable, *map(str, args)],
            cwd=ROOT,
            stdout=write if stdout_closed else subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            timeout=timeout,
            env=env,
        )
    finally:
        os.close(write)


def assert_quiet(done):
    """The command ended with status 0 and without a traceback or a BrokenPipeError."""
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr and "BrokenPipeError" not in done.stderr, done.stderr
