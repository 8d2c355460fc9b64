#!/usr/bin/env bash
# Benchmarks (printed figures): the Rust model and C ABI in process, then fmpy and the
# Python/SciPy peer in the same run, and the NREL electrolyzer package as peer of the hub; last,
# aem-study's year-long scenarios against the FMU's C interface and the NREL peer; the
# prequalification's native steps against a plain fmpy master.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/python packaging/package.py
cargo build --release --locked -p aem-run
echo "== Rust (cargo bench --bench model_step) on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) cores"
cargo bench --locked --profile release --bench model_step -- --json target/bench/rust.json
echo "== fmpy and Python/SciPy"
.venv/bin/python benches/fmpy_bench.py --rust target/bench/rust.json
echo "== hub of 25 000 modules (cargo bench --bench hub; then the equal hub through fmpy)"
cargo bench --locked --profile release --bench hub | tee target/benches/hub.txt
.venv/bin/python benches/hub_fmpy.py
echo "== the NREL electrolyzer package (PyPI) as peer, against the equal hub through fmpy"
bash benches/nrel_bench.sh
echo "== aem-identify against its Python/SciPy peer"
bash benches/identify_bench.sh
echo "== the prequalification's steps: the hub runner (aem_drive) against a plain fmpy master"
.venv/bin/python benches/drive_bench.py
echo "== prequalification of the 25 000-module hub: every product, plain and compensated, with bisection"
.venv/bin/aem-prequalify --modules 25000 --dispatch equal --baseline 80 --compensation both \
  --no-plots --out target/bench/prequalification | tail -1
echo "== the reserve control that sells the most upward FCR-D, 25 000 modules (target <= 5 min)"
.venv/bin/aem-prequalify --modules 25000 --dispatch equal --baseline 80 --compensation both \
  --products "FCR-D up" --optimise --no-plots --out target/bench/optimise | tail -1
echo "== aem-study: a year at 1 s of the 60 MW hub per scenario, scenarios per hour serial and on a LocalCluster, the NREL peer"
.venv/bin/python benches/study_bench.py
