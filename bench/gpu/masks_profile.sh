#!/usr/bin/env bash
# Where the time of the SPH rates pass goes in the flow, with and without hit masks (SPHERIC test 2, float,
# velocity Verlet, after SPH_ADVANCE s of flow): pflow-sph-bench's phase timers for both, and the rates pass of
# SPH_SPLIT further steps timed one at a time (--split-steps), those after a sort (with masks: the marking pass)
# apart from the others. Then Nsight Compute on the first rates pass from rest of each kind (walk, marking walk):
# duration, throughput, registers, occupancy and stalls (a pass deep in the flow is out of ncu's reach in time).
#   bash bench/gpu/masks_profile.sh [spacing]
source "$(dirname "$0")/setup.sh"
sp=${1:-0.006}
adv=${SPH_ADVANCE:-0.32}
split=${SPH_SPLIT:-100}
bw=$(copy_bandwidth)
for mode in walk masks; do
  extra=()
  [[ $mode == masks ]] && extra=(--masks)
  timeout 300 "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" --advance "$adv" \
    --warmup 10 --steps 100 --split-steps "$split" "${extra[@]}" --copy-bandwidth "$bw" --device "$dev" --commit "$commit" \
    >> "$OUT/masks.jsonl" 2>> "$OUT/masks_bench.log"
  echo "$mode rc=$?"
done
NCU=$(command -v ncu || echo /usr/local/cuda/bin/ncu)
for mode in walk masks; do
  extra=() pass=0
  [[ $mode == masks ]] && extra=(--masks) pass=1
  timeout 200 "$NCU" --kernel-name-base demangled --kernel-name regex:"InteractPass<float, .*RatePass.$pass>" --launch-count 1 \
    --section SpeedOfLight --section LaunchStats --section Occupancy --section WarpStateStats --section MemoryWorkloadAnalysis \
    "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" \
    --warmup 1 --steps 1 "${extra[@]}" > "$OUT/ncu_$mode.txt" 2>&1
  echo "ncu $mode rc=$?"
  grep -E "^  void|Duration|Memory Throughput|DRAM Throughput|Compute \(SM\) Throughput|Registers Per|Achieved Occupancy|Theoretical Occupancy|Warp Cycles Per Issued" "$OUT/ncu_$mode.txt" | head -12
done
python3 - "$OUT" <<'PY'
import json, sys
out = sys.argv[1]
for line in open(out + "/masks.jsonl"):
    j = json.loads(line)
    s = j.get("split", {})
    print("masks" if j.get("hit_masks") else "walk", "n=%d" % j["n"], "%.2f ms/step" % j["ms_per_step"], "sorts=%s" % j.get("cell_sorts"),
          "forces after a sort %.2f ms (%d), between %.2f ms (%d)" % (s.get("forces_ms_after_sort", 0), s.get("after_sort", 0),
                                                                    s.get("forces_ms_between_sorts", 0), s.get("between_sorts", 0)))
PY
