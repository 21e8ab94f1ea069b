#!/usr/bin/env bash
# Stops what deploy/local/start.sh started (agent first, so it stops its workers), gracefully, then for sure.
set -uo pipefail
cd "$(dirname "$0")/../.."
dir=${PFLOW_LOCAL:-$(pwd)/out/local}
for name in web agent manager backend frontend; do
  pidfile="$dir/$name.pid"
  [[ -f "$pidfile" ]] || continue
  pid=$(cat "$pidfile")
  if kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid"
    for _ in $(seq 1 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
    kill -0 "$pid" 2>/dev/null && kill -KILL "$pid"
    echo "local: stopped $name (pid $pid)"
  fi
  rm -f "$pidfile"
done
