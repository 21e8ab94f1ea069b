#!/usr/bin/env bash
# The accuracy-speed study in one command (docs/accuracy.md): runs pflow-accuracy, then draws the charts.
# Builds nothing: the binary comes from $PFLOW_BIN or build/bin/pflow-accuracy.
#   bench/accuracy/run.sh [--executor cpu|cuda] [--quick] [other pflow-accuracy options]
# With --executor cuda also the bulk laws of the GPU (pflow-beverloo, pflow-janssen, pflow-repose: Beverloo's,
# Janssen's and the angle of repose's CSVs and charts). Writes docs/accuracy/{study,stability}.csv and PNGs (--quick: build/accuracy-quick/, so the committed
# study is not touched). Rows of the other executor already in study.csv are kept.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin="${PFLOW_BIN:-$root/build/bin}"
[[ -x "$bin" && ! -d "$bin" ]] || bin="$bin/pflow-accuracy"
if [[ ! -x "$bin" ]]; then
  echo "run.sh: no pflow-accuracy at $bin (build it: cmake --build build --target pflow-accuracy, or set PFLOW_BIN)" >&2
  exit 1
fi
# The output directory: --out as given, else docs/accuracy (build/accuracy-quick with --quick).
out="$root/docs/accuracy" given=""
prev=""
for a in "$@"; do
  [[ "$a" == --quick && -z "$given" ]] && out="$root/build/accuracy-quick"
  [[ "$prev" == --out ]] && out="$a" given=1
  [[ "$a" == --out=* ]] && out="${a#--out=}" given=1
  prev="$a"
done
start=$(date +%s)
if [[ -n "$given" ]]; then "$bin" "$@"; else "$bin" --out "$out" "$@"; fi
/usr/bin/python3 "$root/bench/accuracy/plot.py" "$out"
# Chung & Ooi tests 4 and 6 against their published curves (docs/accuracy.md, "Micro-slip"): the regression tests'
# tables.
slip="${PFLOW_TESTS:-$root/build/tests}/micro_slip_test"
if [[ -x "$slip" ]]; then
  PFLOW_CHUNG_OOI_DIR="$out" "$slip" --gtest_filter='*TheirPublishedCurve' > /dev/null
  /usr/bin/python3 "$root/bench/accuracy/plot_chung_ooi.py" "$out" "$root"
fi
# The bulk laws on the GPU (docs/accuracy.md, "Beverloo", "Janssen"): with --executor cuda and not --quick, when
# pflow-beverloo and pflow-janssen were built beside pflow-accuracy.
bindir="$(dirname "$bin")"
if [[ " $* " == *" cuda "* || " $* " == *"--executor=cuda"* ]] && [[ " $* " != *" --quick "* ]]; then
  for p in double float; do
    if [[ -x "$bindir/pflow-beverloo" ]]; then
      "$bindir/pflow-beverloo" --executor cuda --precision "$p" --csv "$out/beverloo_cuda_$p.csv"
    fi
    if [[ -x "$bindir/pflow-janssen" ]]; then
      "$bindir/pflow-janssen" --executor cuda --precision "$p" --csv "$out/janssen_cuda_$p.csv"
    fi
  done
  # The angle of repose (docs/accuracy.md): the poured pile at the paper's mu_r = 0.09 read as pflow's and as Chrono's
  # (0.18 bead-bead here), both doubled (0.36 / 0.18), 0.18 / 0.09 on a floor of glued beads, poured from 25 mm
  # instead of 40, in double, and on a 100 mm platform of glued beads (a fixed base); float but for the one; 250-490 s
  # of GPU each.
  if [[ -x "$bindir/pflow-repose" ]]; then
    "$bindir/pflow-repose" --executor cuda --method pour --precision float --settle 0.2 --rest 0.3 \
      --rolling 0.09,0.18 --wall-rolling 0.09 \
      --csv "$out/repose_poured.csv" --profiles "$out/repose_poured_profiles.csv"
    "$bindir/pflow-repose" --executor cuda --method pour --precision float --settle 0.2 --rest 0.3 \
      --rolling 0.36 --wall-rolling 0.18 \
      --csv "$out/repose_poured_doubled.csv" --profiles "$out/repose_poured_profiles_doubled.csv"
    "$bindir/pflow-repose" --executor cuda --method pour --precision float --settle 0.2 --rest 0.3 \
      --rolling 0.18 --wall-rolling 0.09 --floor beads \
      --csv "$out/repose_poured_beads.csv" --profiles "$out/repose_poured_profiles_beads.csv"
    "$bindir/pflow-repose" --executor cuda --method pour --precision float --settle 0.2 --rest 0.3 \
      --rolling 0.18 --wall-rolling 0.09 --pour-height 0.025 \
      --csv "$out/repose_poured_low.csv" --profiles "$out/repose_poured_profiles_low.csv"
    "$bindir/pflow-repose" --executor cuda --method pour --precision double --settle 0.2 --rest 0.3 \
      --rolling 0.18 --wall-rolling 0.09 \
      --csv "$out/repose_poured_double.csv" --profiles "$out/repose_poured_profiles_double.csv"
    "$bindir/pflow-repose" --executor cuda --method pour --precision float --settle 0.2 --rest 0.3 \
      --rolling 0.18 --wall-rolling 0.09 --floor beads --plate 0.05 \
      --csv "$out/repose_poured_platform.csv" --profiles "$out/repose_poured_profiles_platform.csv"
    for more in doubled beads low double platform; do
      tail -n +2 "$out/repose_poured_$more.csv" >> "$out/repose_poured.csv"
      tail -n +2 "$out/repose_poured_profiles_$more.csv" >> "$out/repose_poured_profiles.csv"
      rm -f "$out/repose_poured_$more.csv" "$out/repose_poured_profiles_$more.csv"
    done
    /usr/bin/python3 "$root/bench/accuracy/plot_repose.py" "$out/repose_poured.png" "$out/repose_poured.csv" "$out/repose_poured_profiles.csv"
  fi
  [[ -s "$out/beverloo_cuda_double.csv" ]] && /usr/bin/python3 "$root/bench/accuracy/plot_beverloo.py" "$out/beverloo.png" "$out"/beverloo_cuda_*.csv
  [[ -s "$out/janssen_cuda_double.csv" ]] && /usr/bin/python3 "$root/bench/accuracy/plot_janssen.py" "$out/janssen.png" "$out"/janssen_cuda_*.csv
fi
echo "run.sh: done in $(( $(date +%s) - start )) s; results in $out" >&2
