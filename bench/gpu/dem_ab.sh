#!/usr/bin/env bash
# A/B of pflow-bench builds in one device call (same machine, same clocks): the settled bed (benchmarks.md) at
# DEM_AB_N (default 4000000) spheres, tiled from one 2e5 bed settled once and shared through --base-cache, timed
# by each binary named on the command line (file names under .gpu/bin after unpacking .gpuz/b.tgz) in
# DEM_AB_PRECISIONS (default float,double), DEM_AB_ROUNDS (default 2) rounds interleaved. JSON lines and logs to $OUT.
#   bash bench/gpu/dem_ab.sh pflow-bench-base pflow-bench
# A name may carry one environment setting after an @ (pflow-bench@PFLOW_TWO_PHASE_PAIRS=0): that binary run with it.
source "$(dirname "$0")/setup.sh"
bw=$(copy_bandwidth)
for round in $(seq 1 "${DEM_AB_ROUNDS:-2}"); do
  for arg in "$@"; do
    if [[ "$arg" == *@* ]]; then (export "${arg#*@}"; bed_run "${arg%%@*}" "$arg" "$round" "$OUT/ab.jsonl")
    else bed_run "$arg" "$arg" "$round" "$OUT/ab.jsonl"; fi
  done
done
bed_table "$OUT/ab.jsonl"
