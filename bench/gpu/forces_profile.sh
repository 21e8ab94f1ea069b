#!/usr/bin/env bash
# The DEM pair-force kernel of each pflow-bench build named on the command line (file names under .gpu/bin),
# profiled by ncu on the settled bed (DEM_PROF_PRECISION, default float; DEM_PROF_N spheres, default 4000000, tiled from the 2e5 bed cached
# in /tmp/beds as dem_ab.sh does): one launch after the resettling and a few steps (the kernel matched by its
# functor's name, so the one-phase loop too under PFLOW_TWO_PHASE_PAIRS=0). Sections to $OUT/ncu_<bin>_<prec>.log,
# a digest on stdout. The digest ends with the stall reasons (warps stalled per issued instruction, largest first),
# the pipes' utilisation and the global loads' sectors per request, from explicit metrics.
#   bash bench/gpu/forces_profile.sh pflow-bench-base pflow-bench
source "$(dirname "$0")/setup.sh"
NCU=$(command -v ncu || echo /usr/local/cuda/bin/ncu)
mkdir -p /tmp/beds
prec=${DEM_PROF_PRECISION:-float}
stalls=""
for r in long_scoreboard short_scoreboard wait math_pipe_throttle mio_throttle lg_throttle tex_throttle barrier \
         not_selected selected no_instruction dispatch_stall branch_resolving drain imc_miss membar sleeping misc; do
  stalls+="smsp__average_warps_issue_stalled_${r}_per_issue_active.ratio,"
done
pipes="sm__inst_executed_pipe_fp64.avg.pct_of_peak_sustained_active,sm__inst_executed_pipe_fma.avg.pct_of_peak_sustained_active,"
pipes+="sm__inst_executed_pipe_alu.avg.pct_of_peak_sustained_active,sm__inst_executed_pipe_lsu.avg.pct_of_peak_sustained_active,"
pipes+="sm__inst_executed_pipe_xu.avg.pct_of_peak_sustained_active,sm__pipe_fp64_cycles_active.avg.pct_of_peak_sustained_active,"
pipes+="l1tex__t_sectors_pipe_lsu_mem_global_op_ld.sum,l1tex__t_requests_pipe_lsu_mem_global_op_ld.sum,"
pipes+="dram__bytes_read.sum,dram__bytes_write.sum,smsp__inst_executed.sum,smsp__thread_inst_executed.sum"
for bin in "$@"; do
  timeout 400 "$NCU" --kernel-name-base demangled --kernel-name regex:"kernels::ComputeForces<$prec" \
    --launch-skip "${DEM_PROF_SKIP:-1005}" --launch-count 1 \
    --section SpeedOfLight --section LaunchStats --section Occupancy --section WarpStateStats --section MemoryWorkloadAnalysis \
    --section MemoryWorkloadAnalysis_Tables \
    --section InstructionStats --section SchedulerStats --metrics "${stalls}${pipes}" \
    "$B/$bin" --base-cache /tmp/beds --executor cuda -n "${DEM_PROF_N:-4000000}" --tile-from 200000 --settle-steps 30000 \
    --resettle-steps 1000 --steps 10 --no-lammps --precision "$prec" > "$OUT/ncu_${bin}_$prec.log" 2>&1
  echo "== $bin rc=$?"
  grep -E "Duration|Memory Throughput|DRAM Throughput|L1/TEX Hit|L2 Hit|Mem Busy|Registers Per|Achieved Occupancy|Theoretical Occupancy|Warp Cycles Per Issued|Block Size|Grid Size|Local|Active Threads Per Warp|Executed Instructions  " "$OUT/ncu_${bin}_$prec.log" | head -22
  grep -E "issue_stalled" "$OUT/ncu_${bin}_$prec.log" | awk '{print $NF, $1}' | sort -rn | head -8
  grep -E "pipe_|sectors_pipe|requests_pipe|dram__bytes|inst_executed.sum" "$OUT/ncu_${bin}_$prec.log" | awk '{print $1, $(NF-1), $NF}'
done
