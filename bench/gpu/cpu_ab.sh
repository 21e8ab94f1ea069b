#!/usr/bin/env bash
# A/B of pflow-bench builds on the CPU executor, all the host's cores, in one device call (same host, same settled
# bed: settled once on the GPU and shared through --base-cache): the 10^6 settled bed (CPU_AB_N), both precisions in
# round 1 with LAMMPS once (after the last binary), double only in round 2. JSON lines and logs to $OUT.
#   bash bench/gpu/cpu_ab.sh pflow-bench-old pflow-bench
source "$(dirname "$0")/setup.sh"
mkdir -p /tmp/beds
cores=$(nproc)
run() { # binary precisions round [extra options]
  local bin=$1 prec=$2 round=$3
  shift 3
  timeout "${CPU_AB_TIMEOUT:-280}" "$B/$bin" --base-cache /tmp/beds --executor cpu --settle-executor cuda -n "${CPU_AB_N:-1000000}" \
    --tile-from 200000 --settle-steps 30000 --resettle-steps 1000 --steps 300 --threads "$cores" --precision "$prec" "$@" \
    --device "$(lscpu | sed -n 's/^Model name: *//p' | head -1), $cores cores" --commit "$commit:$bin" 2>> "$OUT/cpuab.log" \
    | grep '^{' | sed "s/^{/{\"round\":$round,/" >> "$OUT/cpuab.jsonl"
}
last=${!#}
for bin in "$@"; do
  if [[ $bin == "$last" ]]; then run "$bin" double,float 1 --lammps-ranks "$cores"; else run "$bin" double,float 1 --no-lammps; fi
done
for bin in "$@"; do run "$bin" double 2 --no-lammps; done
python3 - "$OUT/cpuab.jsonl" <<'P'
import json, sys
for l in open(sys.argv[1]):
    j = json.loads(l)
    print(j["round"], j.get("code"), j["commit"].split(":")[-1], j.get("precision", "-"), j["n"], "%.3g" % j["particle_steps_per_s"],
          "forces_s=%.3f" % j.get("phases_s", {}).get("forces", 0), "coord=%s" % j.get("coordination"))
P
