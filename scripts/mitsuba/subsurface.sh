#!/usr/bin/env bash
# Subsurface transfer against Mitsuba 3's volumetric path tracer: regenerates the
# held-out references (scripts/mitsuba/subsurface_reference.py, variant scalar_rgb, which needs
# no LLVM) into target/subsurface-references and runs tests/subsurface.rs against them instead
# of the committed table. Mitsuba and NumPy come from PyPI into target/mitsuba-venv, as for
# scripts/mitsuba/run.sh. Extra arguments go to the reference script (e.g. --spp 65536 for
# the committed table's size).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
OUT=target/subsurface-references
# shellcheck source=venv.sh
. "$HERE/venv.sh"

"$VENV/bin/python" "$HERE/subsurface_reference.py" --out "$OUT" --spp 16384 "$@"
# The meshes are the committed ones: the references must be for the same geometry.
for mesh in box sphere slab; do
    cmp -s "$OUT/$mesh.obj" tests/data/subsurface/$mesh.obj ||
        { echo "subsurface.sh: $OUT/$mesh.obj differs from tests/data/subsurface/$mesh.obj" >&2; exit 1; }
done
PRT_SUBSURFACE_REFERENCES="$PWD/$OUT/references.json" \
    cargo test --release --workspace --test subsurface # --workspace: make unit's build, not a new one
