#!/usr/bin/env bash
# Where the time of the SPH rates pass goes in the flow, with and without hit masks (SPHERIC test 2, float,
# velocity Verlet, after SPH_ADVANCE s of flow): pflow-sph-bench's phase timers for both, then Nsight
# Compute on one marking pass in the flow (its duration, throughput and stalls).
#   bash bench/gpu/masks_profile.sh [spacing]
source "$(dirname "$0")/setup.sh"
sp=${1:-0.006}
adv=${SPH_ADVANCE:-0.32}
bw=$(copy_bandwidth)
for mode in walk masks; do
  extra=()
  [[ $mode == masks ]] && extra=(--masks)
  timeout 300 "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" --advance "$adv" \
    --warmup 10 --steps 100 "${extra[@]}" --copy-bandwidth "$bw" --device "$dev" --commit "$commit" >> "$OUT/masks.jsonl" 2>> "$OUT/masks_bench.log"
  echo "$mode rc=$?"
done
# One marking pass (InteractPass<float, RatePass::kMark>) under Nsight Compute: the 300th, well into the flow.
NCU=$(command -v ncu || echo /usr/local/cuda/bin/ncu)
timeout 400 "$NCU" --kernel-name-base demangled --kernel-name regex:'InteractPass<float, .*RatePass.1>' --launch-skip 300 --launch-count 1 \
  --section SpeedOfLight --section LaunchStats --section WarpStateStats \
  "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" --advance "$adv" \
  --warmup 2 --steps 3 --masks > "$OUT/masks_ncu.txt" 2>&1
echo "ncu rc=$?"
grep -E "^  void|Duration|Memory Throughput|Compute \(SM\) Throughput|Registers Per|Warp Cycles Per Issued" "$OUT/masks_ncu.txt" | head -12
python3 - "$OUT" <<'PY'
import json, sys
out = sys.argv[1]
for line in open(out + "/masks.jsonl"):
    j = json.loads(line)
    print("masks" if j.get("hit_masks") else "walk", "n=%d" % j["n"], "%.2f ms/step" % j["ms_per_step"], "sorts=%s" % j.get("cell_sorts"), j.get("phases_s"))
PY
