#!/usr/bin/env bash
# A/B of pflow-bench builds on the CPU executor, all the host's cores, in one device call (same host, same settled
# bed: settled once on the GPU and shared through --base-cache): the 10^6 settled bed (CPU_AB_N), both precisions in
# round 1 with LAMMPS once (after the last binary), double only in round 2. JSON lines and logs to $OUT.
#   bash bench/gpu/cpu_ab.sh pflow-bench-old pflow-bench
# CPU_AB_CPU_ONLY: binaries built without CUDA (-DPFLOW_ENABLE_CUDA=OFF, a couple of minutes each: quick for a
# bisection); they read the bed the last binary (a CUDA build) settled on the GPU, under the CPU's cache name.
# CPU_AB_RESETTLE: steps the tiled bed resettles (default 1000; a CPU-only build resettles on the CPU).
# CPU_AB_FLOAT=0: double only. CPU_AB_LAMMPS=0: no LAMMPS run.
source "$(dirname "$0")/setup.sh"
mkdir -p /tmp/beds
cores=$(nproc)
cpu_only=" ${CPU_AB_CPU_ONLY:-} "
bed=(--base-cache /tmp/beds --tile-from 200000 --settle-steps 30000)  # the settled base bed every run starts from
run() { # binary precisions round [extra options]
  local bin=$1 prec=$2 round=$3 settle=cuda
  shift 3
  [[ $cpu_only == *" $bin "* ]] && settle=cpu
  timeout "${CPU_AB_TIMEOUT:-280}" "$B/$bin" "${bed[@]}" --executor cpu --settle-executor $settle -n "${CPU_AB_N:-1000000}" \
    --resettle-steps "${CPU_AB_RESETTLE:-1000}" --steps 300 --threads "$cores" --precision "$prec" "$@" \
    --device "$(lscpu | sed -n 's/^Model name: *//p' | head -1), $cores cores" --commit "$commit:$bin" 2>> "$OUT/cpuab.log" \
    | grep '^{' | sed "s/^{/{\"round\":$round,/" >> "$OUT/cpuab.jsonl"
}
last=${!#}
if [[ -n ${CPU_AB_CPU_ONLY:-} ]]; then  # settle the bed on the GPU first, then name it for the CPU-only builds
  "$B/$last" "${bed[@]}" --executor cpu --settle-executor cuda -n 200000 --resettle-steps 0 --steps 1 --threads "$cores" \
    --precision double --no-lammps > /dev/null 2>> "$OUT/cpuab.log"
  for f in /tmp/beds/*-cuda.h5; do ln -sf "$f" "${f%-cuda.h5}-cpu.h5"; done
fi
precisions=double,float
[[ ${CPU_AB_FLOAT:-1} == 0 ]] && precisions=double
for bin in "$@"; do
  if [[ $bin == "$last" && ${CPU_AB_LAMMPS:-1} != 0 ]]; then run "$bin" $precisions 1 --lammps-ranks "$cores"; else run "$bin" $precisions 1 --no-lammps; fi
done
for bin in "$@"; do run "$bin" double 2 --no-lammps; done
python3 - "$OUT/cpuab.jsonl" <<'P'
import json, sys
for l in open(sys.argv[1]):
    j = json.loads(l)
    print(j["round"], j.get("code"), j["commit"].split(":")[-1], j.get("precision", "-"), j["n"], "%.3g" % j["particle_steps_per_s"],
          "forces_s=%.3f" % j.get("phases_s", {}).get("forces", 0), "coord=%s" % j.get("coordination"))
P
