#!/usr/bin/env bash
# The column-collapse sweep (docs/accuracy.md, "Column run-out against the published scalings"): the scenes of
# make_scenes.py run one after another with `pflow run` (on the GPU by default: 3 600 to 45 000 grains, 0.25-0.5
# million steps each, about 8 min in all on an H100 (0.2-0.37 ms a step); one process at a time, since processes sharing a GPU time-slice and
# ran about ten times slower per step), then analyze.py writes docs/accuracy/column_runout.{csv,png}.
#   bench/collapse/run.sh [--executor cuda|cpu] [OUTDIR]      (PFLOW_BIN: the folder of pflow, default build/bin)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
executor=cuda
if [[ "${1:-}" == --executor ]]; then executor=$2; shift 2; fi
out=${1:-$root/build/collapse}
bin=${PFLOW_BIN:-$root/build/bin}
mkdir -p "$out"
PFLOW_COLUMN_SCENE=$root/examples/column_collapse.yaml /usr/bin/python3 "$root/bench/collapse/make_scenes.py" "$out/scenes" > /dev/null
for scene in "$out"/scenes/collapse_a*.yaml; do
  name=$(basename "$scene" .yaml)
  start=$(date +%s)
  "$bin/pflow" run "$scene" -o "$out/$name.h5" --executor "$executor" --progress 0 > "$out/$name.log" 2>&1
  echo "run.sh: $name in $(( $(date +%s) - start )) s"
done
/usr/bin/python3 "$root/bench/collapse/analyze.py" "$root/docs/accuracy/column_runout.csv" "$root/docs/accuracy/column_runout.png" \
  "$out"/collapse_a*.h5
