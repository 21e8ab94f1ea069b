#!/usr/bin/env bash
# The Python package's tests (python/tests) as a user would run them: a virtual environment over Debian's
# python3-grpcio, -protobuf, -numpy, -h5py and -yaml (--system-site-packages), `pip install ./python` into it
# (offline: no build isolation, no index; the gRPC stubs generated from proto/ by the package's build), then pytest
# against the real local stack (build/bin). Called by deploy/test.sh after ctest; arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
build=${PFLOW_BUILD_DIR:-$root/build}
venv=$build/python-venv
# Debian's Python (/usr/bin/python3): its dist-packages hold the tested versions (a python3 first on PATH may be another).
[[ -x $venv/bin/python ]] || /usr/bin/python3 -m venv --system-site-packages "$venv"
# The package is built from a copy: setuptools writes build/ and *.egg-info beside its sources.
rm -rf "$build/python-src"
cp -r "$root/python" "$build/python-src"
PFLOW_PROTO_DIR=$root/proto "$venv/bin/pip" install --quiet --no-build-isolation --no-index --force-reinstall --no-deps "$build/python-src"
"$venv/bin/python" -c "import grpc, google.protobuf, numpy, h5py, yaml" || { echo "pytest.sh: the package's dependencies are missing (deploy/install-deps.sh)" >&2; exit 1; }
cd "$build/python-src/tests"  # the installed package, not the sources, is imported
PFLOW_BIN_DIR=$build/bin PFLOW_SRC_DIR=$root OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
  "$venv/bin/python" -m pytest -q -p no:cacheprovider "$@" .
