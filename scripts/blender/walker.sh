#!/usr/bin/env bash
# make blender-walker: scripts/blender/make_walker.py rebuilds the walking character in Blender
# and its GLB must equal the committed scenes/cornell/walker.glb byte for byte (the generator
# is deterministic: its weights are set, not diffused; bpy is pinned). About 3 s after make
# blender (its venv). docs/guides/characters.md, "A character walking through the room".
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=target/blender/venv/bin/python
"$PY" -c 'import bpy' 2>/dev/null || { echo "walker.sh: no bpy in $PY (run make blender)" >&2; exit 2; }
mkdir -p target/blender
"$PY" scripts/blender/make_walker.py target/blender/walker.glb >target/blender/walker.log 2>&1 ||
    { tail -30 target/blender/walker.log; exit 1; }
if cmp -s target/blender/walker.glb scenes/cornell/walker.glb; then
    echo "walker.sh: make_walker.py rebuilds scenes/cornell/walker.glb byte for byte"
else
    echo "walker.sh: make_walker.py's GLB differs from scenes/cornell/walker.glb (commit the new one if the change is meant)" >&2
    exit 1
fi
