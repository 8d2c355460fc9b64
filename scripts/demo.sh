#!/usr/bin/env bash
# Quick start, command 1: build the FMU and the identification tool (target/release/
# aem-identify), then run the demo (a setpoint step schedule in fmpy).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --bins --locked
.venv/bin/python packaging/package.py
.venv/bin/python examples/step_schedule.py "$@"
