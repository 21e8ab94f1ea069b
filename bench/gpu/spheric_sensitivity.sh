#!/usr/bin/env bash
# SPHERIC test 2 (examples/dam_break_3d.yaml): how the first impact on the box moves with the method's knobs.
# Each variant is the example scene with one key changed, run by `pflow run` on the GPU in float to SENS_END s at
# spacing SENS_DP; prints P1/P2 first above 500 Pa, P1's peak and mean, and the gauges against the experiment's
# first-impact window.
#   bash bench/gpu/spheric_sensitivity.sh 'base:' 'alpha0.005:s/artificial_viscosity: 0.02/artificial_viscosity: 0.005/' ...
# A variant is name:sed-expression (empty: the scene as it is). SENS_SAMPLING=mean reads the probes as 1 ms means
# (output.probe_sampling: mean); each variant's probe series stays in $OUT (spheric_<name>.probes.csv).
source "$(dirname "$0")/setup.sh"
dp=${SENS_DP:-0.01}
end=${SENS_END:-0.47}
for v in "$@"; do
  name=${v%%:*}
  expr=${v#*:}
  y="$OUT/spheric_$name.yaml"
  sed -e "s/spacing: 0.02$/spacing: $dp/" -e "s/duration: 1.0$/duration: $end/" -e 's/snapshot_interval: 0.05$/snapshot_interval: 10/' \
      -e 's/^  gravity: \[0, 0, -9.81\]$/  gravity: [0, 0, -9.81]\n  precision: float/' examples/dam_break_3d.yaml > "$y"
  [[ ${SENS_SAMPLING:-instant} == mean ]] && sed -i -e 's/^  probe_interval: 0.001$/  probe_interval: 0.001\n  probe_sampling: mean/' "$y"
  [[ -n $expr ]] && sed -i -e "$expr" "$y"
  start=$SECONDS
  timeout "${SENS_TIMEOUT:-200}" "$B/pflow" run "$y" --executor cuda -o "$OUT/spheric_$name.h5" > "$OUT/spheric_$name.log" 2>&1
  echo "$name rc=$? $((SECONDS - start))s $(grep -E 'done:|error' "$OUT/spheric_$name.log" | tail -1)" >> "$OUT/summary.txt"
  rm -f "$OUT/spheric_$name.h5" "$OUT/spheric_$name.xmf"
done
python3 - "$OUT" "$@" <<'PY' >> "$OUT/summary.txt"
import csv, sys, os
out = sys.argv[1]
def first_above(rows, col, thr=500.0):
    for r in rows:
        if r[col] > thr: return r["t"]
    return float("nan")
def at(rows, col, t):
    for a, b in zip(rows, rows[1:]):
        if a["t"] <= t <= b["t"]:
            w = (t - a["t"]) / (b["t"] - a["t"]); return a[col] * (1 - w) + b[col] * w
    return float("nan")
def window(rows, col, lo, hi):
    return [r[col] for r in rows if lo <= r["t"] <= hi]
print("variant   P1>500Pa        P2>500Pa        P1 peak (0.38-0.462)  P1 mean (0.42-0.462)  H2@.383 H2@.420  H4@.383"
      "  (exp: 0.393 0.410 11.2 kPa 8.6 kPa 0.036 0.058 0.463)")
for v in sys.argv[2:]:
    name = v.split(":")[0]
    f = os.path.join(out, "spheric_%s.probes.csv" % name)
    if not os.path.exists(f): print(name, "no probes"); continue
    rows = []
    with open(f) as fh:
        rd = csv.reader(fh); head = [h.split(" ")[0] for h in next(rd)]
        for r in rd:
            d = dict(zip(head, (float(c) for c in r))); d["t"] = d["time"]; rows.append(d)
    p1, p2 = first_above(rows, "P1"), first_above(rows, "P2")
    w = window(rows, "P1", 0.38, 0.462); m = window(rows, "P1", 0.42, 0.462)
    print("%-9s %.4f (%+.1f%%) %.4f (%+.1f%%) %7.1f kPa           %6.1f kPa             %.4f  %.4f  %.4f" % (
          name, p1, 100 * (p1 / 0.393 - 1), p2, 100 * (p2 / 0.410 - 1), max(w) / 1e3 if w else float("nan"),
          sum(m) / len(m) / 1e3 if m else float("nan"), at(rows, "H2", 0.383), at(rows, "H2", 0.420), at(rows, "H4", 0.383)))
PY
cat "$OUT/summary.txt"
