#!/usr/bin/env bash
# Quick start, command 2: every test. Builds and packages the FMU (linux64 and win64 binaries),
# aem-identify.exe and aem-run for each platform (aem-study's native master), then runs the Rust
# tests (model, C ABI in process, the packaged .fmu through the `fmi` crate, aem-identify on
# synthetic campaigns) and the pytest suite (the packaged .fmu through fmpy, fmpy validate,
# fmutool -check, the win64 DLL, aem-identify.exe and aem-run.exe under Wine, the glibc level,
# the FMI cross-check tree, packaging with identified parameters, aem-study on Dask), then
# fuzzes each byte-level input for 30 s (scripts/fuzz.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --bins --locked
.venv/bin/python packaging/package.py
.venv/bin/python packaging/platforms.py aem-identify --platforms win64
.venv/bin/python packaging/platforms.py aem-run
cargo test --locked
.venv/bin/python -m pytest tests/python -q
bash scripts/fuzz.sh
