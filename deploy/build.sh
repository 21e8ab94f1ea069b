#!/usr/bin/env bash
# Configures and builds pflow into build/ (binaries in build/bin). CUDA code is built when nvcc is found.
set -euo pipefail
cd "$(dirname "$0")/.."
build_type=${PFLOW_BUILD_TYPE:-Release}
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [[ ! -f build/CMakeCache.txt ]]; then
  cmake -S . -B build "${generator[@]}" -DCMAKE_BUILD_TYPE="$build_type" ${PFLOW_CMAKE_ARGS:-}
fi
cmake --build build -j "${PFLOW_JOBS:-$(nproc)}"
