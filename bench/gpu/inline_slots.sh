#!/usr/bin/env bash
# The history pool's inline slots swept (compute/dem/contact/HistoryPool.h): the settled bed of dem_ab.sh timed by
# one pflow-bench binary at PFLOW_INLINE_SLOTS = each argument (0: every history inline), in DEM_AB_PRECISIONS
# (default float), DEM_AB_ROUNDS (default 1) rounds interleaved; prints throughput, the forces phase and bytes a
# particle.   bash bench/gpu/inline_slots.sh pflow-bench 0 5 6 7 8
source "$(dirname "$0")/setup.sh"
bin=$1
shift
bw=$(copy_bandwidth)
export DEM_AB_PRECISIONS=${DEM_AB_PRECISIONS:-float}
for round in $(seq 1 "${DEM_AB_ROUNDS:-1}"); do
  for k in "$@"; do (export PFLOW_INLINE_SLOTS=$k; bed_run "$bin" "inline$k" "$round" "$OUT/inline.jsonl"); done
done
bed_table "$OUT/inline.jsonl"
