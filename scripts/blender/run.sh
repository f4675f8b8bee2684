#!/usr/bin/env bash
# make blender: a Blender-made glTF with per-object lightmap UVs, baked per texel, against
# Blender Cycles' own AO bake (docs/guides/lightmaps.md, "Against Blender Cycles").
#
# Installs Blender 4.5 LTS as a Python module (PyPI `bpy`, about 370 MB, with NumPy) into
# target/blender/venv if it is missing there, builds Suzanne, a cube and a floor with Smart UV
# Project lightmap UVs each in [0, 1], exports scene.glb and bakes Cycles AO of the floor and
# Suzanne (make_scene.py), bakes the GLB with prt-bake --lightmap --aux ao, and compares
# (compare_ao.py: no texel shared between objects; AO within Cycles' noise).
#
# bpy loads X11 and GL client libraries even without a display (Debian 12: libx11-6
# libxrender1 libxfixes3 libxi6 libxkbcommon0 libxext6 libsm6 libice6 libgl1); they are
# installed with apt-get when `import bpy` fails for want of one.
#
# Environment: PYTHON (default python3, which must be 3.11 for bpy 4.5), BAKE (default
# target/release/prt-bake), RES (256), SAMPLES (Cycles' samples, 256), PRT_SAMPLES (1024).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
PYTHON="${PYTHON:-python3}"
BAKE="${BAKE:-target/release/prt-bake}"
RES="${RES:-256}"
SAMPLES="${SAMPLES:-256}"
PRT_SAMPLES="${PRT_SAMPLES:-1024}"
VENV=target/blender/venv
OUT=target/blender/out

has_bpy() { "$1" -c 'import bpy, numpy' >/dev/null 2>&1; }
apt_install() {
    local sudo=""
    [ "$(id -u)" -ne 0 ] && sudo="sudo"
    $sudo apt-get update -qq &&
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

started=$(date +%s.%N)
if ! has_bpy "$VENV/bin/python"; then
    if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c 'import bpy' 2>&1 | grep -q 'cannot open shared object'; then
        rm -rf "$VENV"
        if ! "$PYTHON" -m venv "$VENV" >/dev/null 2>&1 || [ ! -x "$VENV/bin/python" ]; then
            echo "run.sh: no venv module; installing python3-venv"
            apt_install python3-venv
            "$PYTHON" -m venv "$VENV"
        fi
        echo "run.sh: installing Blender 4.5 LTS (bpy) into $VENV"
        "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$HERE/requirements.txt"
    fi
    if "$VENV/bin/python" -c 'import bpy' 2>&1 | grep -q 'cannot open shared object'; then
        echo "run.sh: bpy needs X11/GL client libraries; installing them"
        apt_install libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libxext6 libsm6 libice6 libgl1
    fi
    has_bpy "$VENV/bin/python" || { "$VENV/bin/python" -c 'import bpy'; exit 1; }
fi
installed=$(date +%s.%N)
[ -x "$BAKE" ] || { echo "run.sh: $BAKE is missing (cargo build --release -p prt-baker)" >&2; exit 2; }

rm -rf "$OUT"
"$VENV/bin/python" "$HERE/make_scene.py" "$OUT" --res "$RES" --samples "$SAMPLES" >"$OUT.blender.log" 2>&1 ||
    { tail -30 "$OUT.blender.log"; exit 1; }
blender=$(date +%s.%N)
# --double-sided off: Blender marks every material doubleSided (backface culling off), and
# Cycles' AO and compare_ao.py (the GLB's triangles) know only the front sheets.
"$BAKE" bake "$OUT/scene.glb" -o "$OUT/scene.prt" --lightmap "$RES" --aux ao \
    --samples "$PRT_SAMPLES" --double-sided off --quiet 2>&1 | tee "$OUT/bake.log"
grep -q "each object's UVs are packed" "$OUT/bake.log" ||
    { echo "run.sh: prt-bake did not report the objects' overlapping lightmap UVs" >&2; exit 1; }
baked=$(date +%s.%N)
"$VENV/bin/python" "$HERE/compare_ao.py" "$OUT" "$OUT/scene.prt" --objects Floor,Suzanne
compared=$(date +%s.%N)
awk -v a="$started" -v b="$installed" -v c="$blender" -v d="$baked" -v e="$compared" 'BEGIN {
    printf "run.sh: install check %.1f s, Blender (scene, export, Cycles AO) %.1f s, prt-bake %.1f s, comparison %.1f s\n",
        b - a, c - b, d - c, e - d }'
