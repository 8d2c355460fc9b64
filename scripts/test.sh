#!/usr/bin/env bash
# Quick start, command 2: every test. Installs everything (scripts/setup.sh), lints the Python
# (ruff check, ruff format --check) and checks the Rust formatting,
# builds the release bundle into dist/ (packaging/release.py: the workspace for linux64 against
# glibc 2.17 and for win64, the two-platform FMU, both wheels, the sdist, the plain aem-identify
# downloads, SHA256SUMS), then runs the Rust tests (model, C ABI in process, the packaged .fmu
# through the `fmi` crate, aem-identify on synthetic campaigns) and the pytest suite (the
# packaged .fmu through fmpy and five more importers, the win64 DLL and the commands under Wine,
# the glibc level, the installed wheels and the sdist, the examples, the frameworks, reserves,
# aem-study on Dask, the documentation site built strictly into target/site); beside it, at the
# lowest priority, the fuzzers build and fuzz each byte-level input (scripts/fuzz.sh).
# Each phase's time is printed on stderr. The checkout's commands (aem-identify, aem-run) are the
# release's portable builds in target/dist/linux64/ (aem_electrolyser.locate takes the newer of those and a
# target/release/ build of yours).
set -euo pipefail
cd "$(dirname "$0")/.."
# A full run writes about 10 GB (the two platforms' builds, the fuzzers', .venv, the tests'
# temporary files); on a fuller disk builds and importers fail in ways that say nothing of why.
need_gb=12
free_gb=$(( $(df --output=avail -k . /tmp | tail -n +2 | sort -n | head -1) / 1048576 ))
if [ "$free_gb" -lt "$need_gb" ]; then
  echo "test.sh: $free_gb GB free on the checkout's or /tmp's file system; a full run needs $need_gb GB" >&2
  exit 1
fi
phase() {
  local started=$SECONDS
  "$@"
  echo "test.sh: $* took $((SECONDS - started)) s" >&2
}
phase bash scripts/setup.sh
phase .venv/bin/ruff check --quiet python tests benches packaging fuzz scripts
phase .venv/bin/ruff format --check --quiet python tests benches packaging fuzz scripts
phase cargo fmt --check
phase .venv/bin/python packaging/release.py
phase .venv/bin/python packaging/platforms.py test
# The fuzzers (their own folder, fuzz/target) build at the lowest priority beside pytest, taking
# the CPU it leaves idle while its co-simulations and commands wait, then, once pytest has
# ended, run beside the serial test at normal priority (libFuzzer's timeouts are wall-clock
# time; beside pytest they would take CPU its tests wait for). The build is unoptimised
# here (it builds in half the time); 5 s a target are a smoke test: every harness builds and
# finds nothing in reach. The long runs (release build) are in docs/robustness.md
# (SECONDS_PER_TARGET=3600 or RUNS=10000000 bash scripts/fuzz.sh). A failure elsewhere stops
# the whole tree (cargo and the fuzz loop too). Not a session of their own: the kernel's
# autogroups would then give them half the CPU whatever their niceness.
export FUZZ_PROFILE="${FUZZ_PROFILE:-dev}" SECONDS_PER_TARGET="${SECONDS_PER_TARGET:-5}"
mkdir -p target
rm -f target/pytest-ended
bash -c 'nice -n 19 bash scripts/fuzz.sh build >target/fuzz-build.log 2>&1 || { cat target/fuzz-build.log; exit 1; }
  until [ -e target/pytest-ended ]; do sleep 1; done
  bash scripts/fuzz.sh >target/fuzz-run.log 2>&1; ran=$?; cat target/fuzz-run.log; exit $ran' >target/fuzz.log 2>&1 &
fuzz=$!
kill_tree() { local child; for child in $(pgrep -P "$1"); do kill_tree "$child"; done; kill "$1" 2>/dev/null || true; }
trap 'kill_tree $fuzz' EXIT
phase .venv/bin/python -m pytest tests/python -q -n 2 --dist loadgroup -m "not serial" --durations=20
touch target/pytest-ended
# The sdist's build in the checkout's target folder.
phase .venv/bin/python -m pytest tests/python -q -m serial
fuzzed() { wait $fuzz && cat target/fuzz.log >&2 || { cat target/fuzz.log >&2; return 1; }; }
phase fuzzed
trap - EXIT
echo "test.sh: every test passed in $SECONDS s" >&2
