#!/usr/bin/env bash
# From a fresh machine: install, build, start the whole service stack on loopback (frontend, back-end, manager,
# one node agent: deploy/local/start.sh), submit the hopper-discharge example as a job, watch it, fetch its last
# snapshot, and draw it with `pflow render` (headless Chromium: the web viewer's own drawing code).
#   out/quickstart/hopper.h5 (+ .xmf: open it in ParaView)   out/quickstart/hopper.png, hopper-slice.png
# Run from a terminal, the stack keeps running at the end for the web viewer (http://127.0.0.1:8080; stop it with
# deploy/local/stop.sh); otherwise it is stopped. PFLOW_KEEP_STACK=1 or 0 decides instead.
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
keep=${PFLOW_KEEP_STACK:-$([[ -t 1 ]] && echo 1 || echo 0)}
if [[ "$keep" != 1 ]]; then trap ./deploy/local/stop.sh EXIT; fi
$pflow nodes
job=$($pflow submit examples/hopper_discharge.yaml --json | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])')
echo "submitted $job; watching it (Ctrl-C stops watching, not the job)"
$pflow watch "$job"
$pflow fetch "$job" --last -o out/quickstart/hopper.h5
$pflow render "$job" --last -o out/quickstart/hopper.png
$pflow render out/quickstart/hopper.h5 --slice y=0 --field solid_fraction --streamlines -o out/quickstart/hopper-slice.png
$pflow jobs --all
echo
echo "results:  out/quickstart/hopper.h5 (particles, grid fields, walls; open out/quickstart/hopper.xmf in ParaView)"
echo "pictures: out/quickstart/hopper.png, out/quickstart/hopper-slice.png"
echo "logs:     out/local/logs/   every snapshot of the job: out/local/snapshots/$job.h5"
if [[ "$keep" == 1 ]]; then
  echo "viewer:   http://127.0.0.1:${PFLOW_WEB_PORT:-8080}/#job/$job   sign in with the token in ${PFLOW_LOCAL:-out/local}/admin.token"
  echo "          (the stack keeps running: deploy/local/stop.sh stops it)"
else
  echo "viewer:   http://127.0.0.1:${PFLOW_WEB_PORT:-8080} while the stack runs (PFLOW_KEEP_STACK=1 ./deploy/quickstart.sh keeps it)"
fi
