#!/usr/bin/env bash
# Coverage-guided fuzzing (cargo-fuzz: libFuzzer with AddressSanitizer, release build with
# debug assertions and overflow checks; FUZZ_PROFILE=dev: unoptimised, builds in about half the
# time, runs about ten times slower) of the inputs that come as bytes from outside:
#   fmu_state       fmi2DeSerializeFMUstate through the C ABI (and the state set and stepped)
#   parameter_file  the module parameter file, parsed, validated and simulated as a hub
#   identify_csv    aem-identify's CSV reader and step finder
# Seed corpora are made fresh from valid inputs (fuzz/seeds.py). No panic, abort, leak or
# allocation beyond 512 MB passes. A crash leaves its input in fuzz/artifacts/<target>/.
#
#   bash scripts/fuzz.sh                     # each target for 30 s (scripts/test.sh runs this)
#   SECONDS_PER_TARGET=600 bash scripts/fuzz.sh
#   RUNS=10000000 bash scripts/fuzz.sh       # the long run: 10^7 executions per target
#   bash scripts/fuzz.sh build               # only build the targets (as a run would)
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$PWD/.venv/bin:$PATH"   # cargo-fuzz (requirements.txt)
case "${FUZZ_PROFILE:-release}" in
  release) profile=--release ;;
  dev) profile=--dev ;;
  *) echo "fuzz.sh: FUZZ_PROFILE is release or dev, not ${FUZZ_PROFILE}" >&2; exit 2 ;;
esac
if [ "${1:-}" = build ]; then
  RUSTC_BOOTSTRAP=1 exec cargo fuzz build "$profile" --debug-assertions
fi
limit=(-max_total_time="${SECONDS_PER_TARGET:-30}")
[ -n "${RUNS:-}" ] && limit=(-runs="$RUNS")
.venv/bin/python fuzz/seeds.py
for target in fmu_state parameter_file identify_csv; do
  echo "== fuzz $target (${limit[*]})"
  RUSTC_BOOTSTRAP=1 cargo fuzz run "$profile" --debug-assertions "$target" "fuzz/corpus/$target" -- \
    "${limit[@]}" -max_len=4096 -rss_limit_mb=1024 -malloc_limit_mb=512 -timeout=10 -print_final_stats=1 2>&1 \
    | grep -E '^(Done|stat::number_of_executed_units|stat::peak_rss_mb)|ERROR|SUMMARY|panicked|^#[0-9]+ +DONE'
done
