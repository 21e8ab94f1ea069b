#!/usr/bin/env bash
# A/B of pflow-sph-bench builds in one device call (same machine, same clocks): each binary named on the command
# line (file names under .gpu/bin after unpacking .gpuz/b.tgz) runs SPHERIC test 2 in float with velocity Verlet,
# from rest at SPH_AB_SPACING (default 0.006 m) and in the flow (after 0.32 s) at SPH_AB_FLOW_SPACING (default 0.01 m),
# SPH_AB_ROUNDS times (default 2), interleaved; then the last binary in the flow with the skins in SPH_AB_SKINS. JSON lines and logs to $OUT.
# A binary may carry options after a colon (pflow-sph-bench:--masks): one build with and without a switch.
#   bash bench/gpu/sph_ab.sh pflow-sph-bench-base pflow-sph-bench
#   bash bench/gpu/sph_ab.sh pflow-sph-bench pflow-sph-bench:--masks
source "$(dirname "$0")/setup.sh"
bw=$(copy_bandwidth)
rest=${SPH_AB_SPACING:-0.006}
flow=${SPH_AB_FLOW_SPACING:-0.01}
one() {  # label binary[:options] options...
  local label=$1 spec=$2 bin=${2%%:*} opts=()
  [[ $spec == *:* ]] && read -ra opts <<< "${spec#*:}"
  shift 2
  timeout "${SPH_AB_TIMEOUT:-200}" "$B/$bin" "${opts[@]}" --executor cuda --precision float --integrator velocity_verlet --copy-bandwidth "$bw" \
    --device "$dev" --commit "$commit:$spec" "$@" 2>> "$OUT/ab.log" | sed "s/^{/{\"label\":\"$label\",/" >> "$OUT/ab.jsonl"
}
for round in $(seq "${SPH_AB_ROUNDS:-2}"); do
  for bin in "$@"; do
    one "rest $rest" "$bin" --spacing "$rest" --warmup 10 --steps 50
    one "flow $flow" "$bin" --spacing "$flow" --advance 0.32 --warmup 10 --steps 200
  done
done
last=${!#}
for skin in ${SPH_AB_SKINS:-}; do
  one "flow $flow skin $skin" "$last" --spacing "$flow" --advance 0.32 --warmup 10 --steps 200 --skin "$skin"
done
for sp in ${SPH_AB_FLOW_BIG:-}; do
  one "flow $sp" "$last" --spacing "$sp" --advance 0.32 --warmup 10 --steps 100
done
python3 - "$OUT/ab.jsonl" <<'E'
import json, sys
print("%-26s %-38s %9s %8s %6s" % ("case", "binary", "N", "ms/step", "sorts"))
for l in open(sys.argv[1]):
    try: r = json.loads(l)
    except Exception: continue
    print("%-26s %-38s %9d %8.3f %6d" % (r["label"], r["commit"].split(":", 1)[-1], r["n"], r["ms_per_step"], r.get("cell_sorts", 0)))
E
