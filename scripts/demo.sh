#!/usr/bin/env bash
# Quick start, command 1: builds the FMU (its linux64 binary, for this machine) and runs the demo
# (a setpoint step schedule in fmpy). Installs only what that needs: libclang-dev from apt when
# bindgen cannot find libclang (root or sudo), and .venv with the package (editable), its core
# dependencies (fmpy, numpy, scipy) and matplotlib, at the versions of requirements.txt.
# Needs Debian 12 or Ubuntu 22.04 or newer (x86-64), Rust >= 1.89, Python >= 3.11.
# The full build (the win64 binary too, aem-identify, aem-run) and every test: scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/prerequisites.sh
require_toolchains
require_libclang
require_venv

bash scripts/demo-venv.sh .venv
.venv/bin/python packaging/package.py --platforms linux64 --native
.venv/bin/python -m aem_electrolyser.examples.step_schedule "$@"
