#!/usr/bin/env bash
# Builds the libFuzzer target for the scene loader with clang (ASan + UBSan) into build-fuzz/ and runs it for
# PFLOW_FUZZ_SECONDS (default 60) from a seed corpus of the example scenes. Exits non-zero on a crash, leak,
# sanitizer report or timeout; the reproducer is left in build-fuzz/artifacts/. Then, when the services are built
# (build/tests/rpc_fuzz), sends structured random messages to every RPC of the in-process servers for as long.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${PFLOW_FUZZ_SECONDS:-60}
if ! command -v clang++ >/dev/null; then
  echo "fuzz: clang++ not found; install it with deploy/install-deps.sh" >&2
  exit 1
fi
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [[ ! -f build-fuzz/CMakeCache.txt ]]; then
  CC=clang CXX=clang++ cmake -S . -B build-fuzz "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DPFLOW_BUILD_FUZZ=ON -DPFLOW_BUILD_TESTS=OFF -DPFLOW_BUILD_BENCH=OFF -DPFLOW_ENABLE_CUDA=OFF -DPFLOW_BUILD_SERVICES=OFF >/dev/null
fi
cmake --build build-fuzz -j "${PFLOW_JOBS:-$(nproc)}" --target scene_loader_fuzz
corpus=build-fuzz/corpus
mkdir -p "$corpus" build-fuzz/artifacts
cp examples/*.yaml tests/data/*.yaml "$corpus"/ 2>/dev/null || true
echo "fuzz: scene loader for ${seconds} s"
# -rss_limit_mb guards against inputs that ask for huge allocations; -timeout flags a hang of one input.
build-fuzz/bin/scene_loader_fuzz "$corpus" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
  -artifact_prefix=build-fuzz/artifacts/ -print_final_stats=1 2>&1 | tail -n 15
rc=${PIPESTATUS[0]}
((rc == 0)) || exit "$rc"
if [[ -x build/tests/rpc_fuzz ]]; then
  echo "fuzz: every RPC for ${seconds} s"
  build/tests/rpc_fuzz "$seconds"
fi
