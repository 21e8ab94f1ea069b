#!/usr/bin/env bash
# The test command: installs dependencies, builds, and runs the whole test suite with ctest.
# Extra arguments go to ctest (e.g. ./deploy/test.sh -L unit).
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/install-deps.sh
./deploy/build.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
ctest --test-dir build --output-on-failure --timeout 1800 "$@"
