#!/usr/bin/env bash
# Stops the loopback cluster deploy/slurm/start.sh DIR started (its jobs are killed with it).
set -uo pipefail
dir=${1:?usage: stop.sh DIR}
dir=$(cd "$dir" && pwd) || exit 0
stop_pid() {
  local f=$1
  [[ -f "$f" ]] || return 0
  local pid; pid=$(cat "$f")
  kill "$pid" 2>/dev/null || return 0
  for _ in $(seq 1 50); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  kill -9 "$pid" 2>/dev/null || true
}
export SLURM_CONF="$dir/slurm.conf"
[[ -f "$SLURM_CONF" ]] && scancel --full -u "$(id -un)" 2>/dev/null || true
for f in "$dir"/slurmd-*.pid; do stop_pid "$f"; done
stop_pid "$dir/slurmctld.pid"
stop_pid "$dir/munge/munged.pid"
exit 0
