#!/usr/bin/env bash
# A/B of pflow-bench builds in one device call (same machine, same clocks): the settled bed (benchmarks.md) at
# DEM_AB_N (default 4000000) spheres, tiled from one 2e5 bed settled once and shared through --base-cache, timed
# by each binary named on the command line (file names under .gpu/bin after unpacking .gpuz/b.tgz) in
# DEM_AB_PRECISIONS (default float,double), DEM_AB_ROUNDS (default 2) rounds interleaved. JSON lines and logs to $OUT.
#   bash bench/gpu/dem_ab.sh pflow-bench-base pflow-bench
source "$(dirname "$0")/setup.sh"
bw=$(copy_bandwidth)
mkdir -p /tmp/beds
for round in $(seq 1 "${DEM_AB_ROUNDS:-2}"); do
  for bin in "$@"; do
    timeout "${DEM_AB_TIMEOUT:-240}" "$B/$bin" --base-cache /tmp/beds --executor cuda -n "${DEM_AB_N:-4000000}" \
      --tile-from 200000 --settle-steps 30000 --resettle-steps 1000 --steps 1000 --no-lammps \
      --precision "${DEM_AB_PRECISIONS:-float,double}" --copy-bandwidth "$bw" --device "$dev" --commit "$commit:$bin" \
      2>> "$OUT/ab.log" | grep '^{' | sed "s/^{/{\"round\":$round,/" >> "$OUT/ab.jsonl"
  done
done
python3 - "$OUT/ab.jsonl" <<'E'
import json, sys
print("%-5s %-22s %-7s %9s %12s %9s %9s" % ("round", "binary", "prec", "N", "p-steps/s", "forces_s", "B/part"))
for l in open(sys.argv[1]):
    try: r = json.loads(l)
    except Exception: continue
    ph = r.get("phases_s", {})
    print("%-5s %-22s %-7s %9d %12.3e %9.3f %9.1f" % (r["round"], r["commit"].split(":")[-1], r.get("precision", "?"), r["n"],
          r.get("particle_steps_per_s", 0), ph.get("forces", float("nan")), r.get("device_bytes_per_particle", float("nan"))))
E
