#!/usr/bin/env bash
# From a fresh machine: install, build, start the whole service stack on loopback (frontend, back-end, manager,
# one node agent: deploy/local/start.sh), submit the hopper-discharge example as a job, watch it, fetch its last
# snapshot, and draw it (particles shaded by speed, 3D and side view).
#   out/quickstart/hopper.h5 (+ .xmf: open it in ParaView)   out/quickstart/hopper.png
# The stack is stopped at the end; PFLOW_KEEP_STACK=1 leaves it running (stop it with deploy/local/stop.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/install-deps.sh
./deploy/build.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
pflow=./build/bin/pflow
mkdir -p out/quickstart
$pflow validate examples/hopper_discharge.yaml

./deploy/local/start.sh
export PFLOW_CONFIG=${PFLOW_LOCAL:-$(pwd)/out/local}/config.yaml  # the stack's CA and admin token (start.sh)
if [[ -z "${PFLOW_KEEP_STACK:-}" ]]; then trap ./deploy/local/stop.sh EXIT; fi
$pflow nodes
job=$($pflow submit examples/hopper_discharge.yaml --json | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])')
echo "submitted $job; watching it (Ctrl-C stops watching, not the job)"
$pflow watch "$job"
$pflow fetch "$job" --last -o out/quickstart/hopper.h5
/usr/bin/python3 deploy/tools/render_snapshot.py out/quickstart/hopper.h5 -o out/quickstart/hopper.png
$pflow jobs --all
echo
echo "results: out/quickstart/hopper.h5 (particles, grid fields, walls; open out/quickstart/hopper.xmf in ParaView)"
echo "picture: out/quickstart/hopper.png"
echo "logs:    out/local/logs/   every snapshot of the job: out/local/snapshots/$job.h5"
