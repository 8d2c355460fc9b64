#!/usr/bin/env bash
# Peer benchmark (issue 4): NREL's `electrolyzer` package (PyPI) on a 60-stack, 60 MW PEM plant
# (benches/nrel_peer.py) against our 25 000-module equal hub through fmpy (benches/hub_fmpy.py),
# both one day at 1 s of the same wind-like reference (seed 42), measured in this run; prints
# the ratio. Also the ratio to the Rust C-interface figure when scripts/bench.sh has just
# written it (target/benches/hub.txt, from `cargo bench --bench hub`; this script runs no cargo).
#
#   bash benches/nrel_bench.sh            # the full day (20 min or more on the 2-core dev machine)
#   HOURS=4 bash benches/nrel_bench.sh    # 4 h extrapolated to a day: a lower bound only (the peer's
#                                       # per-step cost grows with simulated time, see nrel_peer.py)
#
# The peer lives in its own .venv-nrel (benches/nrel_requirements.txt, electrolyzer==0.2.1 and
# what pip resolved for it): it is a benchmark peer only, its dependencies are declared
# unpinned, and setup, tests and CI do not need it. Assumes target/fmu/AemElectrolyser.fmu
# (scripts/bench.sh packages it first) and .venv (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
HOURS=${HOURS:-24}
VENV=.venv-nrel
REQ=benches/nrel_requirements.txt

if [ ! -x "$VENV/bin/python" ] || ! cmp -s "$REQ" "$VENV/requirements.installed"; then
  echo "nrel: creating $VENV from $REQ"
  python3 -m venv "$VENV"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check -r "$REQ"
  cp "$REQ" "$VENV/requirements.installed"
fi
[ -f target/fmu/AemElectrolyser.fmu ] || { echo "nrel: target/fmu/AemElectrolyser.fmu missing (run scripts/bench.sh)" >&2; exit 1; }
[ -x .venv/bin/python ] || bash scripts/setup.sh

mkdir -p target/bench
echo "== NREL electrolyzer peer ($HOURS h)"
"$VENV/bin/python" benches/nrel_peer.py --hours "$HOURS" | tee target/benches/nrel.txt
echo "== our FMU through fmpy, the same day"
.venv/bin/python benches/hub_fmpy.py | tee target/benches/hub_fmpy.txt

nrel=$(sed -n 's/^nrel: \([0-9.]*\) s\/day.*/\1/p' target/benches/nrel.txt)
fmpy=$(sed -n 's/.*one day at 1 s: \([0-9.]*\) s\/day.*/\1/p' target/benches/hub_fmpy.txt)
how=$(grep -q EXTRAPOLATED target/benches/nrel.txt && echo "extrapolated from $HOURS h, a lower bound" || echo "measured")
awk -v x="$nrel" -v y="$fmpy" -v how="$how" 'BEGIN {
  printf "== NREL electrolyzer 60 stacks: %.1f s/day (%s); our FMU (25 000 modules, fmpy): %.2f s/day; ratio %.0fx\n", x, how, y, x / y }'
# The Rust C-interface figure, only if `cargo bench --bench hub` wrote it after the FMU was packaged.
if [ -f target/benches/hub.txt ] && [ target/benches/hub.txt -nt target/fmu/AemElectrolyser.fmu ]; then
  rust=$(awk '$1 == "C" && $2 == "ABI" && $3 == "equal" {print $4}' target/benches/hub.txt)
  if [ -n "$rust" ]; then
    awk -v x="$nrel" -v y="$rust" 'BEGIN {
      printf "== our hub through the C interface (cargo bench --bench hub, this run): %.3f s/day; ratio %.0fx\n", y, x / y }'
  fi
fi
