#!/usr/bin/env bash
# SPHERIC test 2 at dp 6.4 mm (float, velocity Verlet, one GPU) to 0.47 s, P1 also 0.5 h and h off the box's face
# into the flow (docs/sph.md, "SPHERIC test 2", "Not the sampling"). Stages: `steps`, the probes read at every step
# ($OUT/spheric_steps.probes.csv, for bench/accuracy/spheric_sampling.py); `instant` and `mean`, every 1 ms with
# output.probe_sampling instant and mean (the runs' wall times give the cost of reading the probes every step).
#   bash bench/gpu/spheric_probes.sh [steps] [instant] [mean]
source "$(dirname "$0")/setup.sh"
end=${SPHERIC_END:-0.47}
make_yaml() {  # $1: probe_interval, $2: probe_sampling (instant|mean; empty: the example's), $3: output
  sed -e "s/spacing: 0.02$/spacing: 0.0064/" -e "s/duration: 1.0$/duration: $end/" \
      -e 's/snapshot_interval: 0.05$/snapshot_interval: 10/' \
      -e '/^  probe_sampling: /d' -e "s/probe_interval: 0.001$/probe_interval: $1${2:+\\n  probe_sampling: $2}/" \
      -e 's/^  gravity: \[0, 0, -9.81\]$/  gravity: [0, 0, -9.81]\n  precision: float/' \
      -e 's/^  - {name: P2, point/  - {name: P1h2, point: [0.8309, 0.471, 0.021]}\n  - {name: P1h, point: [0.8373, 0.471, 0.021]}\n  - {name: P2, point/' \
      examples/dam_break_3d.yaml > "$3"
}
summary=()
for stage in "${@:-steps}"; do
  case $stage in
    steps) make_yaml 0.0000001 "" "$OUT/spheric_steps.yaml" ;;
    instant) make_yaml 0.001 instant "$OUT/spheric_instant.yaml" ;;
    mean) make_yaml 0.001 mean "$OUT/spheric_mean.yaml" ;;
    *) echo "unknown stage $stage" >&2; exit 2 ;;
  esac
  start=$SECONDS
  timeout "${SPHERIC_TIMEOUT:-300}" "$B/pflow" run "$OUT/spheric_$stage.yaml" --executor cuda -o "$OUT/spheric_$stage.h5" > "$OUT/spheric_${stage}_run.log" 2>&1
  summary+=("pflow run SPHERIC $stage rc=$? $((SECONDS - start))s $(grep -E 'done:|probe samples|error' "$OUT/spheric_${stage}_run.log" | tail -2 | tr '\n' ' ')")
  rm -f "$OUT/spheric_$stage.h5" "$OUT/spheric_$stage.xmf"
done
printf '%s\n' "${summary[@]}"
