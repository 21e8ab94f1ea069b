#!/usr/bin/env bash
# One call on the lent GPU machine (see bench/README.md): unpack the bundle built here, run the GPU
# tests, measure the copy bandwidth and the settled-bed throughput, print a short table last.
# Usage (from the repository root on the device machine):
#   bash bench/gpu/device_run.sh [tests] [sanitize] [bench] [scaling] [largest] [cpu] [cpuab] [layouts] [mpi] [model] [accuracy] [sph] [sph3d] [sphmirror] [sphmpi] [sphflow] [sphtarget]
# Logs and JSON go to $OUT (or ./out).
source "$(dirname "$0")/setup.sh"
# Settled small beds kept for every pflow-bench call of this machine (pflow-bench --base-cache): each bed is
# settled once per call, not once per stage. Outside $OUT: they need not come back.
BEDS=${BEDS:-/tmp/pflow-beds}
mkdir -p "$BEDS"
stages=("$@")
((${#stages[@]})) || stages=(tests bench)
has() { local s; for s in "${stages[@]}"; do [[ $s == "$1" ]] && return 0; done; return 1; }
summary=()
nvidia-smi --query-gpu=name,memory.total,clocks.max.sm,driver_version --format=csv,noheader | tee "$OUT/gpu.txt"

if has tests; then
  for t in cuda_executor_test; do
    start=$SECONDS
    "$B/$t" > "$OUT/$t.log" 2>&1
    rc=$?
    summary+=("$t rc=$rc $((SECONDS - start))s $(grep -E '^\[  (PASSED|FAILED)' "$OUT/$t.log" | tr '\n' ' ')")
  done
fi
if has sanitize; then
  for tool in memcheck racecheck; do
    start=$SECONDS
    compute-sanitizer --tool $tool --error-exitcode 9 "$B/cuda_executor_test" \
      --gtest_filter='*SameCandidates*:CudaExecutor.BlowUp*' > "$OUT/sanitizer_$tool.log" 2>&1
    rc=$?
    summary+=("compute-sanitizer $tool rc=$rc $((SECONDS - start))s $(grep -E 'ERROR SUMMARY' "$OUT/sanitizer_$tool.log" | tail -1)")
  done
fi
bw=0
if has bench || has cpu || has scaling || has largest; then
  bw=$(copy_bandwidth)
  summary+=("bandwidth $(cat "$OUT/bandwidth.json")")
fi
if has bench; then
  # One settled 200 000-sphere bed per polydispersity, tiled up to each size (bench/README.md).
  for poly in "" "--poly"; do
    timeout "${BENCH_TIMEOUT:-240}" "$B/pflow-bench" --base-cache "$BEDS" --executor cuda -n "${BENCH_SIZES:-1000000,4000000}" \
      --tile-from 200000 --settle-steps "${SETTLE:-30000}" --resettle-steps "${RESETTLE:-1000}" \
      --steps "${STEPS:-1000}" --no-lammps --precision "${PRECISIONS:-double,float}" --copy-bandwidth "$bw" \
      ${BENCH_ARGS:-} --device "$dev" --commit "$commit" $poly \
      >> "$OUT/bench.jsonl" 2>> "$OUT/bench.log"
    summary+=("bench $poly rc=$?")
  done
fi
# Throughput against size (where one GPU saturates: the manager's --particles-per-gpu), from a 50 000 bed.
if has scaling; then
  timeout "${SCALING_TIMEOUT:-240}" "$B/pflow-bench" --base-cache "$BEDS" --executor cuda -n "${SCALING_SIZES:-50000,100000,200000,500000,1000000,2000000}" \
    --tile-from 50000 --settle-steps "${SETTLE:-30000}" --resettle-steps 500 --steps 1000 --no-lammps \
    --precision double,float --copy-bandwidth "$bw" --device "$dev" --commit "$commit" >> "$OUT/bench.jsonl" 2>> "$OUT/bench.log"
  summary+=("scaling rc=$?")
fi
# The largest beds that fit, one per precision (LARGEST="float:N double:N"), timed briefly.
if has largest; then
  for spec in ${LARGEST:-float:100000000}; do
    timeout "${LARGEST_TIMEOUT:-300}" "$B/pflow-bench" --base-cache "$BEDS" --executor cuda -n "${spec#*:}" --tile-from 200000 \
      --settle-steps "${SETTLE:-30000}" --resettle-steps 300 --steps 300 --no-lammps --precision "${spec%%:*}" \
      --copy-bandwidth "$bw" --device "$dev" --commit "$commit" >> "$OUT/bench.jsonl" 2>> "$OUT/bench.log"
    summary+=("largest $spec rc=$?")
  done
fi
# The CPU executor (every core of the GPU's host) and LAMMPS (one rank per core) on a bed settled on the GPU.
if has cpu; then
  cores=$(nproc)
  for bed in ${CPU_BEDS:-mono poly}; do
    poly=""
    [[ $bed == poly ]] && poly=--poly
    timeout "${CPU_TIMEOUT:-300}" "$B/pflow-bench" --base-cache "$BEDS" --executor cpu --settle-executor cuda -n "${CPU_SIZES:-1000000}" \
      --tile-from 200000 --settle-steps "${SETTLE:-30000}" --resettle-steps "${RESETTLE:-1000}" --steps "${CPU_STEPS:-300}" \
      --threads "$cores" --lammps-ranks "$cores" --precision double,float $poly \
      --device "$(lscpu | sed -n 's/^Model name: *//p' | head -1), $cores cores" \
      --commit "$commit" >> "$OUT/bench.jsonl" 2>> "$OUT/bench.log"
    summary+=("cpu+lammps $poly rc=$?")
  done
fi
# The CPU executor's A/B on the 10^6 mono bed: NUMA first touch (PFLOW_FIRST_TOUCH), thread pinning
# (OMP_PROC_BIND/OMP_PLACES) and dynamic chunks (PFLOW_DYNAMIC_CHUNK), LAMMPS once, and the topology.
if has cpuab; then
  cores=$(nproc)
  { lscpu; ls -d /sys/devices/system/node/node* 2>/dev/null; cat /sys/devices/system/node/node*/cpulist 2>/dev/null; } > "$OUT/topology.txt"
  summary+=("topology: $(lscpu | grep -E '^(Model name|Socket|Core|Thread|NUMA node\(s\)|L3)' | tr -s ' ' | tr '\n' ';')")
  ab() {  # label, env..., -- extra args
    local label=$1; shift
    local envs=()
    while [[ $1 != -- ]]; do envs+=("$1"); shift; done  # VAR=value ... before --, pflow-bench options after
    shift
    env "${envs[@]}" "$B/pflow-bench" --base-cache "$BEDS" --executor cpu --settle-executor cuda -n "${CPU_SIZES:-1000000}" --tile-from 200000 \
      --settle-steps "${SETTLE:-30000}" --resettle-steps "${RESETTLE:-1000}" --steps "${CPU_STEPS:-300}" \
      --precision "${AB_PRECISIONS:-double}" --device "$(lscpu | sed -n 's/^Model name: *//p' | head -1), $cores cores ($label)" \
      --commit "$commit" "$@" >> "$OUT/bench.jsonl" 2>> "$OUT/bench.log"
    summary+=("cpuab $label rc=$?")
  }
  ab "default" -- --threads "$cores" --lammps-ranks "$cores"
  ab "pinned" OMP_PROC_BIND=close OMP_PLACES=cores -- --threads "$cores" --no-lammps
  ab "chunk 64" PFLOW_DYNAMIC_CHUNK=64 -- --threads "$cores" --no-lammps
  ab "chunk 1024" PFLOW_DYNAMIC_CHUNK=1024 -- --threads "$cores" --no-lammps
  ab "static" PFLOW_DYNAMIC_CHUNK=0 -- --threads "$cores" --no-lammps
  ab "first touch off" PFLOW_FIRST_TOUCH=0 -- --threads "$cores" --no-lammps
  CPU_SIZES=4000000 ab "default" -- --threads "$cores" --lammps-ranks "$cores"
fi
# Distributed runs (issue 6): the MPI tests on the GPU, what candidates in id order cost, weak and strong
# scaling over the GPUs when there are several, and the CPU executor's ranks x threads on this host's cores.
if has mpi; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  cores=$(nproc)
  ngpu=$(nvidia-smi -L | wc -l)
  PFLOW_TEST_EXECUTOR=cuda OMP_NUM_THREADS=1 timeout 400 mpirun --oversubscribe -np 2 "$B/distributed_test" > "$OUT/distributed_gpu_np2.log" 2>&1
  summary+=("distributed_test cuda np=2 rc=$? $(grep -E '^\[  (PASSED|FAILED)' "$OUT/distributed_gpu_np2.log" | tr '\n' ' ')")
  mb() {  # ranks, label, args...
    local np=$1 label=$2; shift 2
    timeout "${MPI_TIMEOUT:-300}" mpirun --oversubscribe --bind-to none -np "$np" "$B/pflow-bench-mpi" --device "$label" \
      --commit "$commit" "$@" >> "$OUT/mpi.jsonl" 2>> "$OUT/mpi.log"
    summary+=("bench-mpi np=$np $* rc=$?")
  }
  for c in on off; do
    mb 1 "$dev" --executor cuda --per-rank "${MPI_GPU_N:-4000000}" --tile-from 200000 --settle-steps "${SETTLE:-30000}" \
      --steps "${MPI_GPU_STEPS:-1000}" --overlap on --canonical "$c"
  done
  if ((ngpu > 1)); then
    for np in 1 2 4 8; do
      ((np > ngpu)) && break
      mb "$np" "$ngpu x $dev" --executor cuda --per-rank "${MPI_GPU_N:-4000000}" --tile-from 200000 --settle-steps "${SETTLE:-30000}" --steps "${MPI_GPU_STEPS:-1000}"
      mb "$np" "$ngpu x $dev" --executor cuda --particles 16000000 --tile-from 200000 --settle-steps "${SETTLE:-30000}" --steps "${MPI_GPU_STEPS:-1000}"
    done
  fi
  cpu="$(lscpu | sed -n 's/^Model name: *//p' | head -1), $cores cores"
  for np in ${MPI_CPU_RANKS:-1 2 4 8 16}; do
    mb "$np" "$cpu" --executor cpu --settle-executor cuda --particles "${MPI_CPU_N:-1000000}" --threads $((cores / np)) \
      --tile-from 200000 --settle-steps "${SETTLE:-30000}" --resettle-steps 200 --steps "${MPI_CPU_STEPS:-300}" --overlap both
  done
  summary+=("$(python3 - "$OUT/mpi.jsonl" <<'PY'
import json, sys
for line in open(sys.argv[1]):
    j = json.loads(line)
    ph = j["phases_mean_s"]
    print(f'{j["executor"]} ranks={j["ranks"]} thr={j["threads_per_rank"]} n={j["n"]} overlap={j["overlap"]} canon={j["canonical_order"]} '
          f'{j["particle_steps_per_s"]:.3g} p-s/s comm={100*j["comm_share"]:.1f}% halo={ph["halo"]:.2f}s forces={ph["forces"]:.2f}s '
          f'contacts={ph["contacts"]:.2f}s migrate={ph["migrate"]:.2f}s bnd={100*j["boundary_share_mean"]:.1f}% ghosts/owned={j["ghosts_per_owned"]:.3f} '
          f'busiest={j["busiest_over_mean"]:.3f} wall={j["wall_s"]:.1f}s')
PY
)")
fi
# The least model (issue 7): each simplification on the GPU against the full model (test and benchmark).
if has model; then
  PFLOW_TEST_EXECUTOR=cuda "$B/least_model_test" > "$OUT/least_model_gpu.log" 2>&1
  summary+=("least_model_test cuda rc=$? $(grep -E '^\[  (PASSED|FAILED)' "$OUT/least_model_gpu.log" | tr '\n' ' ')")
  timeout "${MODEL_TIMEOUT:-300}" "$B/pflow-model-bench" --executor cuda -n "${MODEL_N:-500000}" --settle-steps "${MODEL_SETTLE:-10000}" \
    --steps 1000 --repeats 2 --case frictionless,norolling,planar,nowalls --model full,auto > "$OUT/model.jsonl" 2> "$OUT/model.log"
  summary+=("model-bench cuda rc=$? $(tail -3 "$OUT/model.log" | tr '\n' ' ')")
  while read -r line; do summary+=("$line"); done < <(python3 -c '
import json, sys
for l in open(sys.argv[1]):
    j = json.loads(l)
    print(j.get("case"), j.get("model"), "%.3g particle-steps/s" % j.get("particle_steps_per_s", 0))' "$OUT/model.jsonl" 2>/dev/null)
fi
# The accuracy study on the GPU: its rows merged into the committed CSVs (copied in, read back from $OUT).
if has accuracy; then
  mkdir -p "$OUT/accuracy"
  cp docs/accuracy/*.csv "$OUT/accuracy/" 2>/dev/null
  start=$SECONDS
  timeout "${ACCURACY_TIMEOUT:-420}" "$B/pflow-accuracy" --executor cuda --out "$OUT/accuracy" > "$OUT/accuracy.log" 2>&1
  summary+=("pflow-accuracy cuda rc=$? $((SECONDS - start))s")
fi
# SPH (docs/sph.md): the GPU tests against the CPU, the dam break's convergence study on the GPU (double and
# float), and the refined 2D dam break run end to end by `pflow run` (its PERFORMANCE line).
if has sph; then
  for t in sph_gpu_test sph_flow_test; do
    start=$SECONDS
    timeout 600 "$B/$t" > "$OUT/$t.log" 2>&1
    rc=$?
    summary+=("$t rc=$rc $((SECONDS - start))s $(grep -E '^\[  (PASSED|FAILED)|largest CPU-GPU' "$OUT/$t.log" | tr '\n' ' ')")
  done
  for prec in double float; do
    start=$SECONDS
    timeout "${SPH_STUDY_TIMEOUT:-600}" "$B/pflow-accuracy" --solver sph --executor cuda --precision $prec ${SPH_STUDY_ARGS:-} \
      --out "$OUT/sph_$prec" > "$OUT/sph_study_$prec.log" 2>&1
    summary+=("sph study $prec rc=$? $((SECONDS - start))s")
    for f in convergence dam_break_2d; do cp "$OUT/sph_$prec/$f.csv" "$OUT/sph_${prec}_$f.csv" 2>/dev/null; done
    rm -rf "$OUT/sph_$prec"
  done
  summary+=("$(cat "$OUT/sph_study_double.log" | head -40)")
  sed 's/spacing: 0.01 /spacing: 0.002 /' examples/dam_break_2d.yaml > "$OUT/dam_break_2d_refined.yaml"
  timeout 300 "$B/pflow" run "$OUT/dam_break_2d_refined.yaml" --executor cuda -o "$OUT/dam_break_refined.h5" > "$OUT/sph_run.log" 2>&1
  summary+=("pflow run refined 2D rc=$? $(grep -E 'PERFORMANCE|done:' "$OUT/sph_run.log" | tr '\n' ' ')")
  rm -f "$OUT"/dam_break_refined.h5
fi
# SPH in 3D: SPHERIC test 2 (examples/dam_break_3d.yaml) run to 1 s with its probes at 0.02 m, and
# pflow-sph-bench's throughput at SPH_SPACINGS (0.0064 m: about 5 million particles).
if has sph3d; then
  bw=$(copy_bandwidth)
  for prec in ${SPH_PRECISIONS:-float double}; do
    timeout 300 "$B/pflow-sph-bench" --executor cuda --precision $prec --spacing "${SPH_SPACINGS:-0.02,0.01,0.0064}" \
      --warmup "${SPH_WARMUP:-10}" --steps "${SPH_STEPS:-50}" --copy-bandwidth "$bw" --device "$dev" --commit "$commit" \
      >> "$OUT/sph_bench.jsonl" 2>> "$OUT/sph_bench.log"
    summary+=("pflow-sph-bench $prec rc=$?")
  done
  summary+=("$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    j = json.loads(line)
    print(j["precision"], "n=%d" % j["n"], "%.2f ms/step" % j["ms_per_step"], "%.3g p-s/s" % j["particle_steps_per_s"],
          "%.0f B/p" % j["device_bytes_per_particle"], "bw %.2f" % j.get("fraction_of_copy_bandwidth", 0), j["phases_s"])
' "$OUT/sph_bench.jsonl" 2>&1)")
  start=$SECONDS
  timeout "${SPH3D_TIMEOUT:-300}" "$B/pflow" run examples/dam_break_3d.yaml --executor cuda -o "$OUT/dam_break_3d.h5" > "$OUT/sph3d_run.log" 2>&1
  summary+=("pflow run dam_break_3d rc=$? $((SECONDS - start))s $(grep -E 'done:|PERFORMANCE' "$OUT/sph3d_run.log" | tr '\n' ' ')")
  rm -f "$OUT/dam_break_3d.h5" "$OUT/dam_break_3d.xmf"
fi
# Mirror walls (sph.boundary: mirror): the SPH GPU tests, the 2D ladder with mirror walls against Martin & Moyce,
# SPHERIC test 2 with mirror tank walls (the box still of particles): throughput and the probes at 0.01 m.
if has sphmirror; then
  start=$SECONDS
  timeout 300 "$B/sph_gpu_test" > "$OUT/sph_gpu_test.log" 2>&1
  summary+=("sph_gpu_test rc=$? $((SECONDS - start))s $(grep -E '^\[  (PASSED|FAILED)|largest CPU-GPU' "$OUT/sph_gpu_test.log" | tr '\n' ' ')")
  start=$SECONDS
  timeout "${SPH_STUDY_TIMEOUT:-600}" "$B/pflow-accuracy" --solver sph --executor cuda --precision double --only mirror \
    --out "$OUT/sph_mirror" > "$OUT/sph_study_mirror.log" 2>&1
  summary+=("sph study mirror rc=$? $((SECONDS - start))s" "$(grep -E '^mirror|^experiment' "$OUT/sph_study_mirror.log")")
  sed 's/^sph:$/sph:\n  boundary: mirror/' examples/dam_break_3d.yaml > "$OUT/dam_break_3d_mirror.yaml"
  bw=$(copy_bandwidth)
  timeout 300 "$B/pflow-sph-bench" --scene "$OUT/dam_break_3d_mirror.yaml" --executor cuda --precision float \
    --spacing "${SPH_MIRROR_SPACINGS:-0.01,0.0064,0.0055}" --warmup 10 --steps 50 --copy-bandwidth "$bw" --device "$dev" --commit "$commit" \
    >> "$OUT/sph_bench_mirror.jsonl" 2>> "$OUT/sph_bench_mirror.log"
  summary+=("pflow-sph-bench mirror rc=$?")
  # The same machine's baseline: the tank's walls of particles at the middle spacing.
  timeout 300 "$B/pflow-sph-bench" --executor cuda --precision float --spacing 0.0064 --warmup 10 --steps 50 --copy-bandwidth "$bw" \
    --device "$dev" --commit "$commit" >> "$OUT/sph_bench_mirror.jsonl" 2>> "$OUT/sph_bench_mirror.log"
  summary+=("pflow-sph-bench dynamic rc=$?" "$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    j = json.loads(line)
    print(j.get("case", ""), j["precision"], "n=%d" % j["n"], "%.2f ms/step" % j["ms_per_step"], "%.3g p-s/s" % j["particle_steps_per_s"],
          "%.0f B/p" % j["device_bytes_per_particle"], j.get("phases_s", ""))
' "$OUT/sph_bench_mirror.jsonl" 2>&1)")
  sed -i 's/spacing: 0.02$/spacing: 0.01/' "$OUT/dam_break_3d_mirror.yaml"
  start=$SECONDS
  timeout "${SPH3D_TIMEOUT:-400}" "$B/pflow" run "$OUT/dam_break_3d_mirror.yaml" --executor cuda -o "$OUT/spheric_mirror.h5" > "$OUT/sph3d_mirror_run.log" 2>&1
  summary+=("pflow run SPHERIC mirror 0.01 rc=$? $((SECONDS - start))s $(grep -E 'done:|PERFORMANCE' "$OUT/sph3d_mirror_run.log" | tr '\n' ' ')")
  rm -f "$OUT/spheric_mirror.h5" "$OUT/spheric_mirror.xmf"
fi
# SPH on several GPUs (one rank a GPU): the distributed tests on the GPUs against one process, then SPHERIC test 2
# at 1 and 2 ranks (strong: dp 6.4 mm, 4.07e6 particles; weak: dp 5.1 mm, 8.0e6 on 2), symplectic and velocity
# Verlet, the halo overlapped (and once in sequence).
if has sphmpi; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  ngpu=$(nvidia-smi -L | wc -l)
  nvidia-smi topo -m > "$OUT/topo.txt" 2>&1
  for np in 1 2; do
    start=$SECONDS
    PFLOW_TEST_EXECUTOR=cuda OMP_NUM_THREADS=1 timeout 300 mpirun --oversubscribe --bind-to none -np $np "$B/sph_distributed_test" > "$OUT/sph_distributed_gpu_np$np.log" 2>&1
    summary+=("sph_distributed_test cuda np=$np rc=$? $((SECONDS - start))s $(grep -E '^\[  (PASSED|FAILED)|^ranks:' "$OUT/sph_distributed_gpu_np$np.log" | tr '\n' ' ')")
  done
  start=$SECONDS
  timeout 300 "$B/sph_gpu_test" > "$OUT/sph_gpu_test.log" 2>&1
  summary+=("sph_gpu_test rc=$? $((SECONDS - start))s $(grep -E '^\[  (PASSED|FAILED)|largest CPU-GPU' "$OUT/sph_gpu_test.log" | tr '\n' ' ')")
  bw=$(copy_bandwidth)
  sb() {  # ranks, pflow-sph-bench options...
    local np=$1; shift
    timeout "${SPHMPI_TIMEOUT:-150}" mpirun --oversubscribe --bind-to none -np "$np" "$B/pflow-sph-bench" --executor cuda --precision float \
      --warmup 10 --steps 50 --copy-bandwidth "$bw" --device "$((np < ngpu ? np : ngpu)) x $dev" --commit "$commit" "$@" \
      >> "$OUT/sph_mpi.jsonl" 2>> "$OUT/sph_mpi.log"
    summary+=("sph-bench np=$np $* rc=$?")
  }
  for integ in ${SPHMPI_INTEGRATORS:-velocity_verlet symplectic}; do
    for np in 1 2; do
      ((np > ngpu)) && break
      sb $np --integrator $integ --spacing 0.0064
    done
    ((ngpu > 1)) && sb 2 --integrator $integ --spacing 0.0051
  done
  ((ngpu > 1)) && sb 2 --integrator velocity_verlet --spacing 0.0064 --overlap off
  summary+=("$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    j = json.loads(line)
    ph = " ".join("%s=%.3f" % (k, v) for k, v in j.get("phases_max_s", j["phases_s"]).items())
    print(j["integrator"], "ranks=%d gpus=%d" % (j["ranks"], j.get("gpus", 0)), "overlap=" + j["overlap"], "n=%d" % j["n"],
          "%.2f ms/step" % j["ms_per_step"], "%.3g p-s/s" % j["particle_steps_per_s"], "max " + ph, j.get("owned_per_rank", ""))
' "$OUT/sph_mpi.jsonl" 2>&1)")
fi
# SPH in the flow with velocity Verlet (one evaluation a step): pflow-sph-bench timed after 0.32 s (the front on the
# floor), and SPHERIC test 2 run by `pflow run` at dp 6.4 mm (4.07e6 particles, float) to SPHFLOW_END s with its
# probes (robustness: Verlet left the density bounds at 0.31 s there).
if has sphflow; then
  bw=$(copy_bandwidth)
  for sp in ${SPHFLOW_SPACINGS:-0.0064}; do
    timeout 200 "$B/pflow-sph-bench" --executor cuda --precision float --integrator velocity_verlet --spacing "$sp" --advance 0.32 \
      --warmup 10 --steps 100 --copy-bandwidth "$bw" --device "$dev" --commit "$commit" >> "$OUT/sph_flow.jsonl" 2>> "$OUT/sph_flow.log"
    summary+=("sph-bench flow velocity_verlet $sp rc=$? $(tail -2 "$OUT/sph_flow.log" | tr '\n' ' ')")
  done
  sed -e "s/spacing: 0.02$/spacing: ${SPHFLOW_DP:-0.0064}/" -e "s/duration: 1.0$/duration: ${SPHFLOW_END:-0.7}/" \
      -e 's/snapshot_interval: 0.05$/snapshot_interval: 10/' \
      -e 's/^  gravity: \[0, 0, -9.81\]$/  gravity: [0, 0, -9.81]\n  precision: float/' examples/dam_break_3d.yaml > "$OUT/spheric_kdk.yaml"
  start=$SECONDS
  timeout "${SPHFLOW_TIMEOUT:-330}" "$B/pflow" run "$OUT/spheric_kdk.yaml" --executor cuda -o "$OUT/spheric_kdk.h5" > "$OUT/spheric_kdk_run.log" 2>&1
  summary+=("pflow run SPHERIC velocity_verlet float rc=$? $((SECONDS - start))s $(grep -E 'done:|PERFORMANCE|error|range' "$OUT/spheric_kdk_run.log" | tail -3 | tr '\n' ' ')")
  rm -f "$OUT/spheric_kdk.h5" "$OUT/spheric_kdk.xmf"
  summary+=("$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    j = json.loads(line)
    print(j["integrator"], "n=%d" % j["n"], "%.2f ms/step" % j["ms_per_step"], "%.3g p-s/s" % j["particle_steps_per_s"], "sorts=%d" % j["cell_sorts"],
          "t=%.3f" % j["sim_time"], j["phases_s"])
' "$OUT/sph_flow.jsonl" 2>&1)")
fi
# The issue's size (SPHERIC test 2 at dp 6 mm, 4.9e6 particles, velocity Verlet, float): one GPU from rest and in the
# flow (after 0.32 s); two GPUs: the decompositions at dp 6.4 mm from rest, then dp 6 mm in the flow.
if has sphtarget; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  ngpu=$(nvidia-smi -L | wc -l)
  bw=$(copy_bandwidth)
  st() {  # ranks, pflow-sph-bench options...
    local np=$1; shift
    timeout "${SPHT_TIMEOUT:-200}" mpirun --oversubscribe --bind-to none -np "$np" "$B/pflow-sph-bench" --executor cuda --precision float \
      --integrator velocity_verlet --copy-bandwidth "$bw" --device "$np x $dev" --commit "$commit" "$@" \
      >> "$OUT/sph_target.jsonl" 2>> "$OUT/sph_target.log"
    summary+=("sph-bench np=$np $* rc=$?")
  }
  st 1 --spacing 0.006 --warmup 10 --steps 50
  st 1 --spacing 0.006 --advance 0.32 --warmup 10 --steps 100
  if ((ngpu > 1)); then
    st 2 --spacing 0.0064 --warmup 10 --steps 50 --decomposition sfc
    st 2 --spacing 0.0064 --warmup 10 --steps 50 --decomposition multisection
    st 2 --spacing 0.006 --advance 0.32 --warmup 10 --steps 100 --decomposition "${SPHT_DECOMP:-multisection}"
  fi
  summary+=("$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    j = json.loads(line)
    ph = " ".join("%s=%.3f" % (k, v) for k, v in j.get("phases_max_s", j["phases_s"]).items())
    print("ranks=%d" % j["ranks"], j.get("decomposition", ""), "adv=%.2f" % j["advance_s"], "n=%d" % j["n"], "%.2f ms/step" % j["ms_per_step"],
          "%.3g p-s/s" % j["particle_steps_per_s"], "sorts=%d" % j["cell_sorts"], "max " + ph, j.get("owned_per_rank", ""))
' "$OUT/sph_target.jsonl" 2>&1)")
fi
if [[ -s $OUT/bench.jsonl ]]; then
  summary+=("$(python3 - "$OUT/bench.jsonl" <<'PY'
import json, sys
for line in open(sys.argv[1]):
    j = json.loads(line)
    if j.get("code") == "lammps":
        print(f'lammps {j["case"]} n={j["n"]} ranks={j["ranks"]} {j["particle_steps_per_s"]:.3g} p-s/s pflow/lammps={j["pflow_over_lammps"]:.2f}')
        continue
    ph = " ".join(f"{k}={v:.3f}" for k, v in j["phases_s"].items() if v > 0)
    bw = " ".join(f'{k}:{v["gb_per_s"]:.0f}GB/s' for k, v in j.get("traffic", {}).items())
    print(f'{j["executor"]} {j["case"]} {j["precision"]} n={j["n"]} {j["particle_steps_per_s"]:.3g} p-s/s '
          f'{j["device_bytes_per_particle"]:.0f} B/p coord={j["coordination"]:.2f} slots={j["history_slots"]} {ph} {bw}')
PY
)")
fi
if has layouts; then
  for layout in 0 5; do  # candidate rows in slices of 2^layout (0: compressed rows, the default)
    PFLOW_ROW_SLICE_SHIFT=$layout "$B/pflow-bench" --executor cuda -n 1000000 --settle-steps "${SETTLE:-3000}" --steps 500 \
      --no-lammps --device "$dev" --commit "$commit" >> "$OUT/layouts.jsonl" 2>> "$OUT/bench.log"
    summary+=("layout $layout $(tail -1 "$OUT/layouts.jsonl" | python3 -c 'import json,sys; j=json.loads(sys.stdin.read()); print(f"{j[\"particle_steps_per_s\"]:.3g}", j["phases_s"]["forces"], j["phases_s"]["contacts"])' 2>&1)")
  done
fi
echo
echo "== summary ($dev, commit $commit) =="
printf '%s\n' "${summary[@]}"
