#!/usr/bin/env bash
# Benchmark of aem-identify against the Python/SciPy peer (benches/identify_reference.py) on the
# same files, in the same run.
#
# Data: `aem-identify synthesize` writes ten daily CSV files at 1 Hz of a known module, each
# 8⅓ h of operation plus 5 min off before the start-up and after the shut-down (30 000 rows a
# day, 299 740 rows in all after the injected broken rows and gaps: two of each bad-row kind
# and one 30 s gap per file), with sensor noise, temperature dips and disturbed steps.
# Rust: the whole pipeline of `aem-identify fit DIR -o params.json` (read, steps, polarisation,
# dynamics, structure check, hydrogen, report and JSON), release build, wall time measured
# in process by the tool (--timings), best of RUNS; the process's own wall time is shown too.
# Python: the same pipeline in process (interpreter start and imports excluded), best of RUNS.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${RUNS:-5}
PY=${PYTHON:-.venv/bin/python}
[ -x "$PY" ] || { bash scripts/setup.sh; PY=.venv/bin/python; }
cargo build --release --bins --locked -q
TOOL=target/release/aem-identify
DATA=target/bench/identify/days
rm -rf "$DATA"
"$TOOL" synthesize "$DATA" --days 10 --broken
echo "== on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"

best_rust=""
for i in $(seq "$RUNS"); do
  start=$(date +%s%N)
  "$TOOL" fit "$DATA" -o target/bench/identify/params.json --timings >/dev/null 2>target/bench/identify/rust_timings.txt
  end=$(date +%s%N)
  total=$(awk '/timing: total/ {print $3}' target/bench/identify/rust_timings.txt)
  process=$(( (end - start) / 1000000 ))
  if [ -z "$best_rust" ] || awk "BEGIN {exit !($total < $best_rust)}"; then
    best_rust=$total; best_process=$process; cp target/bench/identify/rust_timings.txt target/bench/identify/rust_best.txt
  fi
done
echo "== Rust aem-identify fit (best of $RUNS; process wall time ${best_process} ms)"
sed 's/^timing: /  /' target/bench/identify/rust_best.txt

best_py=""
for i in $(seq "$RUNS"); do
  "$PY" benches/identify_reference.py "$DATA" --json > target/bench/identify/python.txt
  total=$(tail -1 target/bench/identify/python.txt | "$PY" -c 'import json,sys; print(1000*json.load(sys.stdin)["total"])')
  if [ -z "$best_py" ] || awk "BEGIN {exit !($total < $best_py)}"; then
    best_py=$total; cp target/bench/identify/python.txt target/bench/identify/python_best.txt
  fi
done
echo "== Python/SciPy benches/identify_reference.py (best of $RUNS)"
grep '^python: ' target/bench/identify/python_best.txt | sed 's/^python: /  /'
awk -v r="$best_rust" -v p="$best_py" 'BEGIN {printf "== end to end: Rust %.1f ms, Python %.1f ms, ratio %.1fx (target: Rust <= 500 ms)\n", r, p, p / r}'
