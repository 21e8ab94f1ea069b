#!/usr/bin/env bash
# Where the time of the SPH rates pass goes in the flow, with and without neighbour lists (SPHERIC test 2, float,
# velocity Verlet, after SPH_ADVANCE s of flow): pflow-sph-bench's phase timers for both, then an Nsight Systems run
# of the lists mode with its per-kernel GPU time (cuda_gpu_kern_sum): the list builds against the list-driven passes.
#   bash bench/gpu/lists_profile.sh [spacing]
source "$(dirname "$0")/setup.sh"
sp=${1:-0.006}
adv=${SPH_ADVANCE:-0.32}
bw=$(copy_bandwidth)
for mode in walk lists; do
  extra=()
  [[ $mode == lists ]] && extra=(--lists)
  timeout 300 "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" --advance "$adv" \
    --warmup 10 --steps 100 "${extra[@]}" --copy-bandwidth "$bw" --device "$dev" --commit "$commit" >> "$OUT/lists.jsonl" 2>> "$OUT/lists_bench.log"
  echo "$mode rc=$?"
done
NSYS=$(command -v nsys || ls /usr/local/cuda/bin/nsys /opt/nvidia/nsight-systems/*/bin/nsys 2>/dev/null | head -1)
timeout 400 "$NSYS" profile -o "$OUT/lists" --force-overwrite true --trace cuda --sample none --cpuctxsw none \
  "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" --advance "$adv" \
  --warmup 10 --steps 100 --lists > "$OUT/lists_nsys.log" 2>&1
echo "nsys rc=$?"
"$NSYS" stats --report cuda_gpu_kern_sum --format csv -o "$OUT/lists_kern" "$OUT/lists.nsys-rep" > /dev/null 2>&1
ls "$OUT"/lists_kern* 2>/dev/null
python3 - "$OUT" <<'PY'
import csv, glob, json, sys
out = sys.argv[1]
for line in open(out + "/lists.jsonl"):
    j = json.loads(line)
    print("lists" if j.get("neighbour_lists") else "walk", "n=%d" % j["n"], "%.2f ms/step" % j["ms_per_step"], "sorts=%s" % j.get("cell_sorts"), j.get("phases_s"))
for f in glob.glob(out + "/lists_kern*.csv"):
    rows = list(csv.DictReader(open(f)))
    total = sum(float(r["Total Time (ns)"]) for r in rows)
    for r in rows[:12]:
        print("%5.1f%% %10.1f ms %8s calls %9.1f us avg  %s" % (100 * float(r["Total Time (ns)"]) / total, float(r["Total Time (ns)"]) / 1e6,
              r["Instances"], float(r["Avg (ns)"]) / 1e3, r["Name"][:110]))
PY
