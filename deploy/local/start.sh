#!/usr/bin/env bash
# Starts the whole pflow stack on loopback: frontend, back-end, manager and one node agent, each a background
# process with its log and pid under $PFLOW_LOCAL (default out/local). Stop it with deploy/local/stop.sh.
#   ports: manager 50051, frontend 50052, back-end 50053, agent 50061 (override with PFLOW_*_PORT)
# The CLI finds the manager and back-end at these defaults; nothing else to configure.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
bin=${PFLOW_BIN:-$root/build/bin}
dir=${PFLOW_LOCAL:-$root/out/local}
mkdir -p "$dir"/{models,snapshots,agent,logs}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mport=${PFLOW_MANAGER_PORT:-50051} fport=${PFLOW_FRONTEND_PORT:-50052} bport=${PFLOW_BACKEND_PORT:-50053} aport=${PFLOW_AGENT_PORT:-50061}

start() {  # name, command...
  local name=$1; shift
  if [[ -f "$dir/$name.pid" ]] && kill -0 "$(cat "$dir/$name.pid")" 2>/dev/null; then
    echo "local: $name already running (pid $(cat "$dir/$name.pid"))"
    return
  fi
  "$@" >"$dir/logs/$name.log" 2>&1 &
  echo $! >"$dir/$name.pid"
  echo "local: started $name (pid $!, log $dir/logs/$name.log)"
}

start frontend "$bin/pflow-frontend" --listen "127.0.0.1:$fport" --models "$dir/models"
start backend "$bin/pflow-backend" --listen "127.0.0.1:$bport" --data "$dir/snapshots"
start manager "$bin/pflow-manager" --listen "127.0.0.1:$mport" --db "$dir/manager.db" \
  --frontend "127.0.0.1:$fport" --backend "127.0.0.1:$bport"
start agent "$bin/pflow-agent" --node "${PFLOW_NODE:-$(hostname -s)}" --listen "127.0.0.1:$aport" \
  --manager "127.0.0.1:$mport" --workdir "$dir/agent" --worker "$bin/pflow-worker"

# Ready when the manager lists the agent's node.
for _ in $(seq 1 100); do
  if "$bin/pflow" --manager "127.0.0.1:$mport" nodes --json 2>/dev/null | grep -q '"devices":\[{'; then
    echo "local: stack ready (manager 127.0.0.1:$mport)"
    exit 0
  fi
  sleep 0.2
done
echo "local: the stack did not become ready in 20 s; logs in $dir/logs" >&2
exit 1
