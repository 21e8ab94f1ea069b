# Sourced by the device-machine scripts of bench/gpu (device_run.sh, sph_ab.sh, profile_rates.sh): unpacks the
# bundle built here, loads its environment, and sets OUT (logs, JSON: $OUT or ./out), B (the binaries), dev (the
# GPU's name), commit (.gpuz/commit). copy_bandwidth measures the device copy bandwidth once per call (GB/s; 0 when
# it cannot) into $OUT/bandwidth.json and prints it.
set -uo pipefail
OUT=${OUT:-out}
mkdir -p "$OUT"
tar xzf .gpuz/b.tgz
source .gpu/env.sh
B=.gpu/bin
dev=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -1)
commit=$(cat .gpuz/commit 2>/dev/null || echo unknown)
copy_bandwidth() {
  [[ -s "$OUT/bandwidth.json" ]] || "$B/pflow-gpu-bandwidth" > "$OUT/bandwidth.json" 2>&1
  python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["memcpy_gb_per_s"])' "$OUT/bandwidth.json" 2>/dev/null || echo 0
}
# The settled bed of dem_ab.sh timed once by binary $1 (a file under $B), labelled $2 in the JSON's commit, appended
# with round $3 to the JSON-lines file $4: DEM_AB_N spheres (default 4000000) tiled from one 2e5 bed settled once and
# shared through /tmp/beds, in DEM_AB_PRECISIONS (default float,double); DEM_AB_ARGS adds pflow-bench arguments
# (--poly: the polydisperse bed). Needs bw (copy_bandwidth) set.
bed_run() {
  mkdir -p /tmp/beds
  timeout "${DEM_AB_TIMEOUT:-240}" "$B/$1" --base-cache /tmp/beds --executor cuda -n "${DEM_AB_N:-4000000}" \
    --tile-from 200000 --settle-steps 30000 --resettle-steps 1000 --steps 1000 --no-lammps \
    --precision "${DEM_AB_PRECISIONS:-float,double}" ${DEM_AB_ARGS:-} --copy-bandwidth "$bw" --device "$dev" --commit "$commit:$2" \
    2>> "$OUT/bed.log" | grep '^{' | sed "s/^{/{\"round\":$3,/" >> "$4"
}
# A table of bed_run's JSON lines in file $1: round, label, precision, N, throughput, forces phase, bytes a particle
# at the end and at the peak.
bed_table() {
  python3 - "$1" <<'E'
import json, sys
print("%-5s %-22s %-7s %9s %12s %9s %9s %9s" % ("round", "binary", "prec", "N", "p-steps/s", "forces_s", "B/part", "peak"))
for l in open(sys.argv[1]):
    try: r = json.loads(l)
    except Exception: continue
    ph = r.get("phases_s", {})
    print("%-5s %-22s %-7s %9d %12.3e %9.3f %9.1f %9.1f" % (r["round"], r["commit"].split(":")[-1], r.get("precision", "?"), r["n"],
          r.get("particle_steps_per_s", 0), ph.get("forces", float("nan")), r.get("device_bytes_per_particle", float("nan")),
          r.get("device_peak_bytes_per_particle", float("nan"))))
E
}
