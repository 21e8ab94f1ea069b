#!/usr/bin/env bash
# The test command: installs dependencies, builds, runs the whole test suite with ctest, then the Python package's
# pytest suite (deploy/pytest.sh) and fuzzes the scene loader and the RPCs for 30 s each (deploy/fuzz.sh). Extra arguments go to ctest (e.g. ./deploy/test.sh -L unit) and skip the
# fuzzing.
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/install-deps.sh
./deploy/build.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
ctest --test-dir build --output-on-failure --timeout 1800 "$@"
if (($# == 0)); then
  ./deploy/pytest.sh   # the Python package, installed with pip into a venv, against the real stack
  PFLOW_FUZZ_SECONDS=${PFLOW_FUZZ_SECONDS:-30} ./deploy/fuzz.sh   # 30 s a fuzzer here (CI time); longer by hand
fi
