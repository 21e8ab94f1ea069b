# Sourced by the device-machine scripts of bench/gpu (device_run.sh, sph_ab.sh, profile_rates.sh): unpacks the
# bundle built here, loads its environment, and sets OUT (logs, JSON: $OUT or ./out), B (the binaries), dev (the
# GPU's name), commit (.gpuz/commit). copy_bandwidth measures the device copy bandwidth once per call (GB/s; 0 when
# it cannot) into $OUT/bandwidth.json and prints it.
set -uo pipefail
OUT=${OUT:-out}
mkdir -p "$OUT"
tar xzf .gpuz/b.tgz
source .gpu/env.sh
B=.gpu/bin
dev=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -1)
commit=$(cat .gpuz/commit 2>/dev/null || echo unknown)
copy_bandwidth() {
  [[ -s "$OUT/bandwidth.json" ]] || "$B/pflow-gpu-bandwidth" > "$OUT/bandwidth.json" 2>&1
  python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["memcpy_gb_per_s"])' "$OUT/bandwidth.json" 2>/dev/null || echo 0
}
