#!/usr/bin/env bash
# Starts the whole pflow stack on loopback: frontend, back-end, manager and one node agent, each a background
# process with its log and pid under $PFLOW_LOCAL (default out/local). Stop it with deploy/local/stop.sh.
#   ports: manager 50051, frontend 50052, back-end 50053, agent 50061, web viewer 8080 (override with PFLOW_*_PORT)
# Mutual TLS between the services (docs/security.md): on first start it makes the pflow CA and the services'
# certificates in $PFLOW_LOCAL/tls (deploy/local/certs.sh), and the manager makes user 'admin', whose token goes to
# $PFLOW_LOCAL/admin.token. The CLI's settings (addresses, CA, token) go to $PFLOW_LOCAL/config.yaml, and to
# ~/.config/pflow/config.yaml when that does not exist yet; else use PFLOW_CONFIG=$PFLOW_LOCAL/config.yaml.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
bin=${PFLOW_BIN:-$root/build/bin}
dir=${PFLOW_LOCAL:-$root/out/local}
mkdir -p "$dir"/{models,snapshots,agent,logs}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mport=${PFLOW_MANAGER_PORT:-50051} fport=${PFLOW_FRONTEND_PORT:-50052} bport=${PFLOW_BACKEND_PORT:-50053} aport=${PFLOW_AGENT_PORT:-50061}
wport=${PFLOW_WEB_PORT:-8080}

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

node=${PFLOW_NODE:-$(hostname -s)}
tls="$dir/tls"
"$root/deploy/local/certs.sh" "$tls" manager frontend backend web "node:$node" | sed 's/^/local: /'
start frontend "$bin/pflow-frontend" --listen "127.0.0.1:$fport" --models "$dir/models" --tls-dir "$tls"
start backend "$bin/pflow-backend" --listen "127.0.0.1:$bport" --data "$dir/snapshots" --manager "127.0.0.1:$mport" --tls-dir "$tls"
start manager "$bin/pflow-manager" --listen "127.0.0.1:$mport" --db "$dir/manager.db" \
  --frontend "127.0.0.1:$fport" --backend "127.0.0.1:$bport" --tls-dir "$tls" --admin-token-file "$dir/admin.token"
start agent "$bin/pflow-agent" --node "$node" --listen "127.0.0.1:$aport" \
  --manager "127.0.0.1:$mport" --workdir "$dir/agent" --worker "$bin/pflow-worker" --tls-dir "$tls"
start web "$bin/pflow-web" --listen "127.0.0.1:$wport" --manager "127.0.0.1:$mport" --backend "127.0.0.1:$bport" --tls-dir "$tls" \
  --static "${PFLOW_WEB_PAGE:-$(dirname "$bin")/web}"

# The first admin's token: written by the manager on its first start.
for _ in $(seq 1 100); do [[ -s "$dir/admin.token" ]] && break; sleep 0.1; done
if [[ ! -s "$dir/admin.token" ]]; then
  echo "local: the manager wrote no $dir/admin.token; logs in $dir/logs" >&2
  exit 1
fi
umask 077
printf 'manager: 127.0.0.1:%s\nbackend: 127.0.0.1:%s\nca: %s\ntoken: %s\n' "$mport" "$bport" "$tls/ca.crt" "$(cat "$dir/admin.token")" \
  > "$dir/config.yaml"
user_config="${HOME:-/nonexistent}/.config/pflow/config.yaml"
if [[ ! -e "$user_config" && -n "${HOME:-}" && -z "${PFLOW_NO_USER_CONFIG:-}" ]]; then
  mkdir -p "$(dirname "$user_config")" && cp "$dir/config.yaml" "$user_config"
  echo "local: CLI settings (admin token) in $user_config"
else
  echo "local: CLI settings (admin token) in $dir/config.yaml: export PFLOW_CONFIG=$dir/config.yaml"
fi

# Ready when the manager lists the agent's node.
for _ in $(seq 1 100); do
  if PFLOW_CONFIG="$dir/config.yaml" "$bin/pflow" nodes --json 2>/dev/null | grep -q '"devices":\[{'; then
    echo "local: stack ready (manager 127.0.0.1:$mport, TLS); the viewer: http://127.0.0.1:$wport (sign in with the token in $dir/admin.token)"
    exit 0
  fi
  sleep 0.2
done
echo "local: the stack did not become ready in 20 s; logs in $dir/logs" >&2
exit 1
