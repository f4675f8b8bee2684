#!/usr/bin/env bash
# Subsurface transfer against Mitsuba 3's volumetric path tracer (issue 31): regenerates the
# held-out references (scripts/mitsuba/subsurface_reference.py, variant scalar_rgb, which needs
# no LLVM) into target/subsurface-references and runs tests/subsurface.rs against them instead
# of the committed table. Mitsuba and NumPy come from PyPI into target/mitsuba-venv, as for
# scripts/mitsuba/run.sh. Extra arguments go to the reference script (e.g. --spp 65536 for
# the committed table's size).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
PYTHON="${PYTHON:-python3}"
VENV="${MITSUBA_VENV:-target/mitsuba-venv}"
OUT=target/subsurface-references

if ! "$VENV/bin/python" -c 'import mitsuba, numpy' >/dev/null 2>&1; then
    rm -rf "$VENV"
    if ! "$PYTHON" -m venv "$VENV" >/dev/null 2>&1 || [ ! -x "$VENV/bin/python" ]; then
        echo "subsurface.sh: '$PYTHON -m venv' is unavailable (Debian: apt-get install python3-venv)" >&2
        exit 2
    fi
    echo "subsurface.sh: installing Mitsuba 3 and NumPy into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$HERE/requirements.txt"
fi

"$VENV/bin/python" "$HERE/subsurface_reference.py" --out "$OUT" --spp 16384 "$@"
# The meshes are the committed ones: the references must be for the same geometry.
for mesh in box sphere slab; do
    cmp -s "$OUT/$mesh.obj" tests/data/subsurface/$mesh.obj ||
        { echo "subsurface.sh: $OUT/$mesh.obj differs from tests/data/subsurface/$mesh.obj" >&2; exit 1; }
done
PRT_SUBSURFACE_REFERENCES="$PWD/$OUT/references.json" \
    cargo test --release -p prt-tests --test subsurface
