#!/usr/bin/env bash
# Quick start, command 2: every test. Builds and packages the FMU, then runs the Rust tests
# (model, C ABI in process, the packaged .fmu through the `fmi` crate, aem-identify on
# synthetic campaigns) and the pytest suite (the packaged .fmu through fmpy, fmpy validate,
# fmutool -check, packaging with identified parameters, the validation plot).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --bins --locked
.venv/bin/python packaging/package.py
cargo test --locked
.venv/bin/python -m pytest tests/python -q
