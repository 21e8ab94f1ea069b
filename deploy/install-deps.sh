#!/usr/bin/env bash
# Installs every Debian package pflow builds, tests and benchmarks with. Idempotent: packages already
# present are skipped without touching apt.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libgtest-dev libgmock-dev         # tests
  libopenmpi-dev openmpi-bin        # MPI (multi-rank compute)
  libhdf5-dev                       # snapshot files
  libspdlog-dev                     # logging
  libyaml-cpp-dev                   # scene files
  libcli11-dev                      # command line
  nlohmann-json3-dev                # JSON output
  python3 python3-h5py python3-numpy python3-matplotlib   # pictures and file checks
  python3-grpcio python3-protobuf python3-yaml   # the Python package (python/) and the services' Python clients
  python3-venv python3-pip python3-setuptools python3-wheel python3-pytest python3-tqdm python3-xarray   # its install and tests
  lammps                            # the reference code the benchmark compares with
  clang                             # libFuzzer for the scene-loader fuzz target (deploy/fuzz.sh)
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler   # services
  libsqlite3-dev sqlite3            # the manager's job store
  libssl-dev openssl                # token hashes; the pflow CA and service certificates (deploy/local/certs.sh)
  libcpp-httplib-dev                # pflow-web (the web viewer's HTTP side)
  chromium fonts-dejavu-core        # pflow render and the browser tests (headless, software WebGL)
  slurm-wlm munge                   # --placement slurm and its tests (deploy/slurm/: a one-node cluster on loopback)
)
# Node.js and npm bundle the viewer's page (web/): the machine's own when present, else Debian's.
command -v node >/dev/null && command -v npm >/dev/null || packages+=(nodejs npm)

npm_packages() {  # the page's npm packages, pinned by web/package-lock.json, from the npm registry
  local web
  web="$(cd "$(dirname "$0")/../web" && pwd)"
  if [[ ! -f "$web/node_modules/.package-lock.json" || "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ]]; then
    echo "install-deps: npm ci in web/"
    (cd "$web" && npm ci --no-audit --no-fund --loglevel=error)
  fi
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  npm_packages
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
npm_packages
