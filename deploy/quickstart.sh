#!/usr/bin/env bash
# The most complete thing pflow does today, from a fresh machine: install, build, run the demo scene
# (beads settling in a box) with `pflow run`, and write its results and a picture.
#   out/quickstart/settling_box.h5 (+ .xmf: open it in ParaView)   out/quickstart/settling_box.png
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/install-deps.sh
./deploy/build.sh
mkdir -p out/quickstart
./build/bin/pflow validate examples/settling_box.yaml
./build/bin/pflow run examples/settling_box.yaml -o out/quickstart/settling_box.h5
/usr/bin/python3 deploy/tools/render_snapshot.py out/quickstart/settling_box.h5 -o out/quickstart/settling_box.png
echo
echo "results: out/quickstart/settling_box.h5 (open out/quickstart/settling_box.xmf in ParaView)"
echo "picture: out/quickstart/settling_box.png"
