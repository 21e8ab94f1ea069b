#!/usr/bin/env bash
# The accuracy-speed study in one command (docs/accuracy.md): runs pflow-accuracy, then draws the charts.
# Builds nothing: the binary comes from $PFLOW_BIN or build/bin/pflow-accuracy.
#   bench/accuracy/run.sh [--executor cpu|cuda] [--quick] [other pflow-accuracy options]
# Writes docs/accuracy/{study,stability}.csv and PNGs (--quick: build/accuracy-quick/, so the committed
# study is not touched). Rows of the other executor already in study.csv are kept.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin="${PFLOW_BIN:-$root/build/bin}"
[[ -x "$bin" && ! -d "$bin" ]] || bin="$bin/pflow-accuracy"
if [[ ! -x "$bin" ]]; then
  echo "run.sh: no pflow-accuracy at $bin (build it: cmake --build build --target pflow-accuracy, or set PFLOW_BIN)" >&2
  exit 1
fi
# The output directory: --out as given, else docs/accuracy (build/accuracy-quick with --quick).
out="$root/docs/accuracy" given=""
prev=""
for a in "$@"; do
  [[ "$a" == --quick && -z "$given" ]] && out="$root/build/accuracy-quick"
  [[ "$prev" == --out ]] && out="$a" given=1
  [[ "$a" == --out=* ]] && out="${a#--out=}" given=1
  prev="$a"
done
start=$(date +%s)
if [[ -n "$given" ]]; then "$bin" "$@"; else "$bin" --out "$out" "$@"; fi
/usr/bin/python3 "$root/bench/accuracy/plot.py" "$out"
echo "run.sh: done in $(( $(date +%s) - start )) s; results in $out" >&2
