#!/usr/bin/env bash
# Regenerates the pictures of docs/display.md: pflow render and pflow plot of a hopper run and a 2-D dam break, and
# the page's screenshots (tests/browser/browser_test.cjs screenshots, against a local stack of its own).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=docs/display
tmp=$(mktemp -d)
trap 'node tests/browser/browser_test.cjs teardown "$tmp/stack" >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
pflow=build/bin/pflow
$pflow run examples/hopper_discharge.yaml -o "$tmp/hopper.h5" --steps 40000 --progress 0 >/dev/null
$pflow run examples/dam_break_2d.yaml -o "$tmp/dam.h5" --steps 3000 --progress 0 >/dev/null
$pflow render "$tmp/hopper.h5" --title hopper_discharge.yaml -o $out/render-hopper.png
$pflow render "$tmp/hopper.h5" --title hopper_discharge.yaml --slice y=0 --streamlines -o $out/render-hopper-slice.png
$pflow render "$tmp/dam.h5" --title dam_break_2d.yaml --color-by pressure -o $out/render-dam.png
$pflow render "$tmp/dam.h5" --title dam_break_2d.yaml --slice y=0 --field mean_velocity --streamlines -o $out/render-dam-slice.png
$pflow plot "$tmp/hopper.h5" --title hopper_discharge.yaml -o $out/plot-hopper.png
PFLOW_SRC=$(pwd) PFLOW_BIN=$(pwd)/build/bin node tests/browser/browser_test.cjs setup "$tmp/stack" >/dev/null
PFLOW_SRC=$(pwd) PFLOW_BIN=$(pwd)/build/bin node tests/browser/browser_test.cjs screenshots "$tmp/stack" $out
