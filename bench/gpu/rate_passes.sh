#!/usr/bin/env bash
# The SPH rates pass's variants timed one after another from the same flow (SPHERIC test 2, float, velocity Verlet,
# after SPH_ADVANCE s): pflow-sph-bench --variants, each with --split-steps (the pass after a sort apart from the
# others). The order alternates (walk, masks, walk, masks) so that the drift of the flow over the run shows.
#   bash bench/gpu/rate_passes.sh [spacing]
source "$(dirname "$0")/setup.sh"
sp=${1:-0.006}
adv=${SPH_ADVANCE:-0.32}
variants=${SPH_VARIANTS:-walk,masks,walk,masks}
bw=$(copy_bandwidth)
timeout 500 "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" --advance "$adv" \
  --warmup 10 --steps 100 --split-steps "${SPH_SPLIT:-100}" --variants "$variants" --copy-bandwidth "$bw" --device "$dev" \
  --commit "$commit" >> "$OUT/rate_passes.jsonl" 2>> "$OUT/rate_passes.log"
echo "bench rc=$?"
python3 - "$OUT" <<'PY'
import json, sys
print("| variant | ms/step | sorts | forces after a sort [ms] | forces between sorts [ms] |")
print("|---|---|---|---|---|")
for line in open(sys.argv[1] + "/rate_passes.jsonl"):
    j = json.loads(line)
    s = j.get("split", {})
    print("| %s | %.2f | %s | %.2f (%d) | %.2f (%d) |" % (j["rate_pass"], j["ms_per_step"], j["cell_sorts"], s.get("forces_ms_after_sort", 0),
          s.get("after_sort", 0), s.get("forces_ms_between_sorts", 0), s.get("between_sorts", 0)))
PY
