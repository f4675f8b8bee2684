#!/usr/bin/env bash
# Tests the NumPy-only .prt reader (scripts/python/prt.py) against prt-bake's npz export, and
# the EXR export against the npz export (with OpenEXR's Python bindings).
# Uses the reference check's environment (target/reference-venv) when it has NumPy, else
# python3 if it has NumPy, else makes target/python-venv with NumPy.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
PYTHON="${PYTHON:-python3}"
if target/reference-venv/bin/python -c 'import numpy' >/dev/null 2>&1; then
    PY=target/reference-venv/bin/python
elif target/python-venv/bin/python -c 'import numpy' >/dev/null 2>&1; then
    PY=target/python-venv/bin/python
elif "$PYTHON" -c 'import numpy' >/dev/null 2>&1; then
    PY="$PYTHON"
else
    echo "run-tests.sh: installing numpy into target/python-venv"
    "$PYTHON" -m venv target/python-venv
    target/python-venv/bin/python -m pip install --quiet --disable-pip-version-check numpy
    PY=target/python-venv/bin/python
fi
# OpenEXR's Python bindings (a PyPI wheel) read the EXR export independently of the exr crate.
if ! "$PY" -c 'import OpenEXR' >/dev/null 2>&1; then
    case "$PY" in
        target/*) echo "run-tests.sh: installing OpenEXR into ${PY%/bin/python}"
                  "$PY" -m pip install --quiet --disable-pip-version-check OpenEXR \
                      || echo "run-tests.sh: OpenEXR did not install: the EXR export is not checked" ;;
        *) echo "run-tests.sh: $PY has no OpenEXR module: the EXR export is not checked" ;;
    esac
fi
cargo build --release --workspace # make build's features: -p prt-baker alone resolves them anew and rebuilds every dependency
exec "$PY" "$HERE/test_prt.py" target/release/prt-bake target/python-reader
