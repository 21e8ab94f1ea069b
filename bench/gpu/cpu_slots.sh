#!/usr/bin/env bash
# The CPU's pairs once with more inline history slots than it needs (pflow-bench --history-slots, each argument),
# the 10^6 settled bed (CPU_SLOTS_N) in double on all the host's cores, two rounds interleaved: whether the forces
# phase pays for the slots' capacity (bytes streamed past) or only for the slots used. The bed is settled once on
# the GPU and shared through --base-cache. docs/performance.md, "The CPU executor on the same host".
#   bash bench/gpu/cpu_slots.sh 8 16 24
source "$(dirname "$0")/setup.sh"
mkdir -p /tmp/beds
cores=$(nproc)
for round in 1 2; do
  for k in "$@"; do
    timeout 280 "$B/pflow-bench" --base-cache /tmp/beds --tile-from 200000 --settle-steps 30000 --executor cpu --settle-executor cuda \
      -n "${CPU_SLOTS_N:-1000000}" --resettle-steps 1000 --steps 300 --threads "$cores" --precision double --no-lammps \
      --history-slots "$k" --device "$(lscpu | sed -n 's/^Model name: *//p' | head -1), $cores cores" --commit "$commit:slots$k" \
      2>> "$OUT/cpuslots.log" | grep '^{' | sed "s/^{/{\"round\":$round,/" >> "$OUT/cpuslots.jsonl"
  done
done
python3 - "$OUT/cpuslots.jsonl" <<'P'
import json, sys
for l in open(sys.argv[1]):
    j = json.loads(l)
    print(j["round"], j["commit"].split(":")[-1], j["n"], "%.3g p-s/s" % j["particle_steps_per_s"], "forces_s=%.3f" % j["phases_s"]["forces"],
          "slots=%s" % j.get("history_slots"), "B/part=%.0f" % j.get("device_bytes_per_particle", 0))
P
