#!/usr/bin/env bash
# A source-level Nsight Compute profile of the SPH rates pass (SPHERIC test 2, float, velocity Verlet), on the
# device machine: per-SASS-instruction counts (executed warp instructions, active threads) with the CUDA line each
# comes from (the build has -lineinfo), and the pass's summary sections. Run from the repository root there:
#   bash bench/gpu/profile_rates.sh [spacing] [kernel name] [extra pflow-sph-bench options...]
# Writes $OUT/rates.ncu-rep, $OUT/rates_source.csv (the source page), $OUT/rates_details.txt.
source "$(dirname "$0")/setup.sh"
sp=${1:-0.0064}
kernel=${2:-forEachKernelCapped}  # ncu matches the function's base name: the register-capped launcher of the rates pass
shift 2 2>/dev/null || shift $#
NCU=$(command -v ncu || ls /usr/local/cuda/bin/ncu 2>/dev/null || echo ncu)
# The 40th launch of the pass: past the block-size tuning (the first launches of a kernel try 64..512 threads).
"$NCU" --kernel-name "$kernel" --launch-skip 40 --launch-count 1 \
  --section SourceCounters --section WarpStateStats --section SchedulerStats --section InstructionStats \
  --section LaunchStats --section Occupancy --section SpeedOfLight --section MemoryWorkloadAnalysis \
  --import-source yes -f -o "$OUT/rates" \
  "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" \
  --warmup 60 --steps 5 "$@" > "$OUT/rates_run.log" 2>&1
echo "ncu rc=$?"
"$NCU" -i "$OUT/rates.ncu-rep" --page details > "$OUT/rates_details.txt" 2>&1
"$NCU" -i "$OUT/rates.ncu-rep" --page source --csv --print-source cuda,sass > "$OUT/rates_source.csv" 2> "$OUT/rates_source.err" ||
  "$NCU" -i "$OUT/rates.ncu-rep" --page source --csv > "$OUT/rates_source.csv" 2>> "$OUT/rates_source.err"
wc -c "$OUT"/rates_* | tail -5
grep -E "Duration|Executed Instructions |Registers Per|Achieved Occupancy|Avg. Active Threads|Issue Slots Busy|Warp Cycles Per Issued" \
  "$OUT/rates_details.txt" | head -20
