#!/usr/bin/env bash
# Seed 002's GPU/CPU comparison at the sizes where it means something: SPHERIC test 2 (3D) and the 2D dam break
# from 10^4 to 10^7 particles, the H100 against the 16 cores of its host (OpenMP, all threads), float and double,
# velocity Verlet from rest. A JSON line per run in $OUT/sph_cpu_gpu.jsonl; a table last.
#   bash bench/gpu/sph_cpu_gpu.sh
source "$(dirname "$0")/setup.sh"
bw=$(copy_bandwidth)
cores=$(nproc)
run() {  # executor precision scene spacings steps
  local ex=$1 prec=$2 scene=$3 sp=$4 steps=$5 dv="$dev"
  [[ $ex == cpu ]] && dv="$(lscpu | sed -n 's/^Model name: *//p' | head -1), $cores cores"
  timeout 400 "$B/pflow-sph-bench" --scene "$scene" --executor "$ex" --precision "$prec" --integrator velocity_verlet \
    --spacing "$sp" --warmup 2 --steps "$steps" --copy-bandwidth "$bw" --device "$dv" --commit "$commit" \
    >> "$OUT/sph_cpu_gpu.jsonl" 2>> "$OUT/sph_cpu_gpu.log"
  echo "$ex $prec $scene $sp rc=$?"
}
for prec in float double; do
  run cuda $prec examples/dam_break_2d.yaml 0.003,0.0015 50
  run cpu $prec examples/dam_break_2d.yaml 0.003,0.0015 10
  run cuda $prec examples/dam_break_3d.yaml 0.04,0.02,0.01,0.006,0.0047 20
  run cpu $prec examples/dam_break_3d.yaml 0.04,0.02,0.01 4
  run cpu $prec examples/dam_break_3d.yaml 0.006,0.0047 2
done
python3 - "$OUT/sph_cpu_gpu.jsonl" <<'PY'
import json, sys
rows = {}
for line in open(sys.argv[1]):
    j = json.loads(line)
    rows.setdefault((j["case"], j["precision"], j["spacing"]), {})[j["executor"]] = j
print("| case | precision | N | GPU ms/step | CPU ms/step | GPU speed-up |")
print("|---|---|---|---|---|---|")
for (case, prec, sp), r in sorted(rows.items(), key=lambda kv: (kv[0][0], kv[0][1], -kv[0][2])):
    g, c = r.get("cuda"), r.get("cpu")
    n = (g or c)["n"]
    gm = g["ms_per_step"] if g else float("nan")
    cm = c["ms_per_step"] if c else float("nan")
    print("| %s dp %g | %s | %s | %.3f | %.1f | %.1f |" % (case.split("/")[-1], sp, prec, n, gm, cm, cm / gm))
PY
