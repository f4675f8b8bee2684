#!/usr/bin/env bash
# make blender-addon: the Blender add-on (runtime/blender/prt_bake) in Blender 4.5
# LTS (bpy in target/blender/venv, installed by `make blender`, scripts/blender/run.sh).
#
# Packs the add-on (make_zip.py), installs it from the zip into a throw-away Blender user
# folder, builds Suzanne, a cube and a floor, bakes them through bpy.ops.prt.bake, relights
# at the rig and turned 90° (test_addon.py; also the errors, the cancel, the preview
# material, and that only attributes were added), bakes Blender's own glTF export of the
# scene with the CLI at the same settings and exports it lit by the rig and by the rig turned
# 90° (COLOR_0), and compares per object (compare_cli.py: mean within 3 %, per-vertex
# correlation ≥ 0.98). test_courtyard.py: the production courtyard through the add-on against
# the CLI on Blender's export of it, per vertex and per lightmap texel (≥ 99 % within 2 %,
# every object, at the rig and turned 90°), and failing with cut-outs, textures or instances
# (and, per texel, normal maps) switched off.
# test_scatter.py: a collection instance and a geometry-nodes scatter of 1,000 instances cast
# shadows, in memory that grows with meshes, not instances.
# test_ldprt.py: an armature-bent tube baked with LDPRT through the add-on, its shading as the
# armature plays (frame-change handler) against `prt-bake relight --pose` at three frames
# (≥ 99 % of corners within 2 %), failing with the lobes left in their rest frames.
#
# Environment: BAKE (default target/release/prt-bake), SAMPLES (1024).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
BAKE="$(realpath "${BAKE:-target/release/prt-bake}")"
SAMPLES="${SAMPLES:-1024}"
PY=target/blender/venv/bin/python
OUT="$(pwd)/target/blender/addon"

[ -x "$BAKE" ] || { echo "test.sh: $BAKE is missing (cargo build --release -p prt-baker)" >&2; exit 2; }
"$PY" -c 'import bpy' >/dev/null 2>&1 ||
    { echo "test.sh: no bpy in $PY: run make blender first (it installs Blender 4.5)" >&2; exit 2; }

started=$(date +%s.%N)
rm -rf "$OUT"
mkdir -p "$OUT/user" "$OUT/user-legacy" "$OUT/tmp"
# Blender's session folders (blender_XXXXXX) stay behind when a test leaves through os._exit:
# they go into the test's own folder, which the next run removes, not into /tmp.
export TMPDIR="$OUT/tmp"
python3 "$HERE/make_zip.py" "$OUT/prt_bake.zip"
# The rig: a directional light and a hemisphere sky; and the same turned 90° about +z
# ((x, y, z) -> (-y, x, z)), what the add-on's light_rotation = 90° must reproduce.
rig() {
    cat <<TOML
[[light]]
kind = "directional"
direction = [$1, $2, 0.8]
intensity = 1.6

[[light]]
kind = "hemisphere"
color = [0.25, 0.3, 0.4]
ground_color = [0.05, 0.05, 0.05]
TOML
}
rig 0.5 -0.35 >"$OUT/rig.toml"
rig 0.35 0.5 >"$OUT/rig90.toml"

# bpy can hang in its exit handlers: test_addon.py writes its results to files and leaves
# through os._exit; the timeout is a guard, and stdout goes to a file, never a pipe.
timeout 600 env BLENDER_USER_RESOURCES="$OUT/user" "$PY" "$HERE/test_addon.py" \
    "$OUT/prt_bake.zip" "$BAKE" "$OUT/rig.toml" "$OUT" --samples "$SAMPLES" \
    >"$OUT/blender.log" 2>&1 || { cat "$OUT/blender.log"; exit 1; }
# The same zip as a legacy add-on, in a Blender of its own with a fresh user folder.
timeout 300 env BLENDER_USER_RESOURCES="$OUT/user-legacy" "$PY" "$HERE/test_addon.py" \
    "$OUT/prt_bake.zip" "$BAKE" "$OUT/rig.toml" "$OUT" --legacy \
    >"$OUT/blender-legacy.log" 2>&1 || { cat "$OUT/blender-legacy.log"; exit 1; }
# The production courtyard against the CLI per vertex (every feature switched off once), and
# a collection instance with a geometry-nodes scatter of 1,000 instances.
mkdir -p "$OUT/user-courtyard" "$OUT/user-scatter" "$OUT/user-ldprt"
timeout 600 env BLENDER_USER_RESOURCES="$OUT/user-courtyard" "$PY" "$HERE/test_courtyard.py" \
    "$OUT/prt_bake.zip" "$BAKE" "$OUT/rig.toml" "$OUT/rig90.toml" "$OUT/courtyard" \
    --samples "$SAMPLES" >"$OUT/courtyard.log" 2>&1 || { cat "$OUT/courtyard.log"; exit 1; }
timeout 600 env BLENDER_USER_RESOURCES="$OUT/user-scatter" "$PY" "$HERE/test_scatter.py" \
    "$OUT/prt_bake.zip" "$BAKE" "$OUT/rig.toml" "$OUT/scatter" \
    >"$OUT/scatter.log" 2>&1 || { cat "$OUT/scatter.log"; exit 1; }
ldprt_started=$(date +%s.%N)
timeout 300 env BLENDER_USER_RESOURCES="$OUT/user-ldprt" "$PY" "$HERE/test_ldprt.py" \
    "$OUT/prt_bake.zip" "$BAKE" "$OUT/rig.toml" "$OUT/rig90.toml" "$OUT/ldprt" \
    >"$OUT/ldprt.log" 2>&1 || { cat "$OUT/ldprt.log"; exit 1; }
ldprt_done=$(date +%s.%N)
grep -hE '^(ok|FAIL) ' "$OUT/blender.log" "$OUT/blender-legacy.log" "$OUT/courtyard.log" \
    "$OUT/scatter.log" "$OUT/ldprt.log" | cut -c1-400
awk -v a="$ldprt_started" -v b="$ldprt_done" 'BEGIN { printf "test.sh: LDPRT (test_ldprt.py) %.1f s\n", b - a }'
"$PY" - "$OUT/checks.json" "$OUT/checks-legacy.json" "$OUT/courtyard/checks-courtyard.json" \
    "$OUT/scatter/checks-scatter.json" "$OUT/ldprt/checks-ldprt.json" <<'PY'
import json, sys
checks = {k: v for path in sys.argv[1:] for k, v in json.load(open(path)).items()}
bad = [name for name, c in checks.items() if not c["ok"]]
sys.exit(f"test.sh: add-on checks failed: {', '.join(bad)}" if bad or len(checks) < 8 else 0)
PY
addon=$(date +%s.%N)

# --double-sided off: Blender's exporter marks the materials doubleSided, and the add-on bakes
# with its default Double-sided off (a Blender mesh holds one transfer per corner).
"$BAKE" bake "$OUT/scene.glb" -o "$OUT/cli.prt" --order 4 --samples "$SAMPLES" --quiet --double-sided off
"$BAKE" bake "$OUT/scene.glb" -o "$OUT/cli-ir.prt" --order 4 --samples 256 \
    --mode interreflected --quiet --double-sided off
for turn in 0 90 ir; do
    rigfile="$OUT/rig.toml"
    [ "$turn" = 90 ] && rigfile="$OUT/rig90.toml"
    prt="$OUT/cli.prt"
    [ "$turn" = ir ] && prt="$OUT/cli-ir.prt"
    "$BAKE" export "$prt" --scene "$OUT/scene.glb" --gltf "$OUT/cli$turn.glb" \
        --lights "$rigfile" >/dev/null
done
"$PY" "$HERE/compare_cli.py" "$OUT"
compared=$(date +%s.%N)
awk -v a="$started" -v b="$addon" -v c="$compared" 'BEGIN {
    printf "test.sh: Blender (install, scene, add-on bake, checks) %.1f s, CLI bake and comparison %.1f s\n", b - a, c - b }'
