#!/usr/bin/env bash
# The history pool's inline slots swept (compute/dem/contact/HistoryPool.h): the settled bed of dem_ab.sh timed by
# one pflow-bench binary at PFLOW_INLINE_SLOTS = each argument (0: every history inline), in DEM_AB_PRECISIONS
# (default float), DEM_AB_ROUNDS rounds interleaved; prints throughput, the forces phase and bytes a particle.
#   bash bench/gpu/inline_slots.sh pflow-bench 0 5 6 7 8
source "$(dirname "$0")/setup.sh"
bin=$1
shift
bw=$(copy_bandwidth)
mkdir -p /tmp/beds
for round in $(seq 1 "${DEM_AB_ROUNDS:-1}"); do
  for k in "$@"; do
    PFLOW_INLINE_SLOTS=$k timeout "${DEM_AB_TIMEOUT:-240}" "$B/$bin" --base-cache /tmp/beds --executor cuda -n "${DEM_AB_N:-4000000}" \
      --tile-from 200000 --settle-steps 30000 --resettle-steps 1000 --steps 1000 --no-lammps \
      --precision "${DEM_AB_PRECISIONS:-float}" --copy-bandwidth "$bw" --device "$dev" --commit "$commit:inline$k" \
      2>> "$OUT/inline.log" | grep '^{' | sed "s/^{/{\"round\":$round,/" >> "$OUT/inline.jsonl"
  done
done
python3 - "$OUT/inline.jsonl" <<'E'
import json, sys
print("%-5s %-10s %-7s %9s %12s %9s %9s" % ("round", "inline", "prec", "N", "p-steps/s", "forces_s", "B/part"))
for l in open(sys.argv[1]):
    try: r = json.loads(l)
    except Exception: continue
    ph = r.get("phases_s", {})
    print("%-5s %-10s %-7s %9d %12.3e %9.3f %9.1f" % (r["round"], r["commit"].split(":")[-1], r.get("precision", "?"), r["n"],
          r.get("particle_steps_per_s", 0), ph.get("forces", float("nan")), r.get("device_bytes_per_particle", float("nan"))))
E
