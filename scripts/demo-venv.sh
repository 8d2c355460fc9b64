#!/usr/bin/env bash
# The demo's Python environment (scripts/demo.sh; tests/python/platforms/test_quick_start.py runs
# this very script into a fresh venv): a venv at $1 (default .venv) made by python3 -m venv, and
# into it, with that venv's own pip (the one the interpreter bundles: 23.x on Python 3.11), this
# package (editable) with its core dependencies (fmpy, numpy, scipy) and matplotlib, at the
# versions of requirements.txt taken as constraints. pip refuses a constraints file that holds
# extras ("Constraints cannot have extras"): requirements.txt names none (a test checks it).
# Nothing is installed when the venv already imports the package and matplotlib. --no-compile:
# pip's compiling every module of numpy, scipy and matplotlib at install is half its CPU time;
# the demo compiles (and keeps) only those it imports.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${1:-.venv}"
if [ ! -x "$venv/bin/python" ]; then
  echo "demo: creating $venv"
  python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import aem_electrolyser, matplotlib' 2>/dev/null; then
  echo "demo: installing the package (editable) with fmpy, numpy, scipy and matplotlib into $venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check --no-compile -c requirements.txt -e ".[plots]"
fi
