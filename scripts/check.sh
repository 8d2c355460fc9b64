#!/usr/bin/env bash
# The fast lane, for every change (about 2 to 3 minutes on two cores after a first build):
# formatting and lint of the Rust and the Python, the model's and the identification's unit
# tests, the linux64 FMU rebuilt natively where the sources changed, the FMU's integration
# tests (its C interface in process: random call sequences, the workspace's dependency
# directions; the packaged .fmu through the `fmi` crate), and the pytest tests that
# are not marked slow, wine, cosim, cluster or serial (those run in scripts/test.sh, the full
# suite). Needs the set-up of scripts/demo.sh or scripts/setup.sh (a .venv with the package).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ ! -x .venv/bin/python ]]; then
  echo "check.sh: no .venv here: run scripts/demo.sh (or scripts/setup.sh) once first" >&2
  exit 1
fi
phase() {
  local started=$SECONDS
  "$@"
  echo "check.sh: $* took $((SECONDS - started)) s" >&2
}
phase cargo fmt --all --check
phase .venv/bin/ruff check --quiet python tests benches packaging fuzz scripts
phase .venv/bin/ruff format --check --quiet python tests benches packaging fuzz scripts
phase cargo clippy --quiet --workspace --all-targets --release -- -D warnings
phase cargo test --quiet -p aem-model -p aem-identify --lib   # debug assertions and overflow checks on
phase .venv/bin/python packaging/package.py --platforms linux64 --native
phase cargo test --quiet --release --test integration --test robustness_report   # C ABI, packaged .fmu, docs/robustness.md
phase .venv/bin/python -m pytest tests/python -q -n 2 --dist loadgroup -p no:cacheprovider \
  -m "not slow and not wine and not cosim and not cluster and not serial"
echo "check.sh: passed in $SECONDS s" >&2
