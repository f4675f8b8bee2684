#!/usr/bin/env bash
# make blender-production: the production-style courtyard (scenes/production/courtyard.glb:
# alpha-cut foliage cards, a normal-mapped wall, linked-duplicate crates), made in Blender by
# make_production.py, baked per texel by prt-bake and checked against Cycles' own AO bake
# (docs/guides/production-assets.md, "The production courtyard").
#
# 1. Blender rebuilds the scene, exports the GLB (check_glb.py: it must equal the committed
#    one, and have cut-out cards, a normal map with tangents, a shared mesh) and bakes Cycles' AO of the ground and the wall into their Lightmap UVs.
# 2. prt-bake bakes the committed GLB (--lightmap RES --aux ao); compare_ao.py requires the
#    ground and the wall's faces (Wall/0) within Cycles' noise (and the transfer's DC under a
#    uniform sky equals that AO, so the transfer is checked too).
# 3. The same GLB with alphaMode stripped (cards opaque) must FAIL on the ground, and with
#    normalTexture stripped (wall flat) must FAIL on the wall.
# 4. A vertex bake of the ground (--receivers Ground) with --instances on (the five crates
#    traced as instances of one mesh) and off: the ground's transfer and AO bit for bit equal.
#
# Needs make blender's venv (target/blender/venv). Environment: BAKE (target/release/prt-bake),
# RES (prt-bake's atlas, 256), CYCLES_RES (each object's Cycles image, 128), SAMPLES (Cycles'
# samples, 128), PRT_SAMPLES (512).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
BAKE="${BAKE:-target/release/prt-bake}"
RES="${RES:-256}"
CYCLES_RES="${CYCLES_RES:-128}"
SAMPLES="${SAMPLES:-128}"
PRT_SAMPLES="${PRT_SAMPLES:-512}"
PY=target/blender/venv/bin/python
OUT=target/blender/production
GLB=scenes/production/courtyard.glb

"$PY" -c 'import bpy, numpy' 2>/dev/null || { echo "production.sh: no bpy in $PY (run make blender)" >&2; exit 2; }
[ -x "$BAKE" ] || { echo "production.sh: $BAKE is missing (cargo build --release -p prt-baker)" >&2; exit 2; }
started=$(date +%s.%N)
rm -rf "$OUT"
mkdir -p "$OUT"
"$PY" "$HERE/make_production.py" "$OUT" --res "$CYCLES_RES" --samples "$SAMPLES" >"$OUT.blender.log" 2>&1 ||
    { tail -30 "$OUT.blender.log"; exit 1; }
rc=0
"$PY" "$HERE/check_glb.py" "$OUT/courtyard.glb" "$GLB" || rc=$?
if [ "$rc" -eq 3 ]; then
    GLB="$OUT/courtyard.glb" # another Blender 4.5.x: Cycles' scene state is its export's
    "$PY" "$HERE/check_glb.py" "$GLB" "$GLB"
elif [ "$rc" -ne 0 ]; then
    exit "$rc"
fi
blender=$(date +%s.%N)

compare() { # NAME OBJECTS: compare_ao.py's verdict on $OUT/NAME.prt, its figures in NAME.json
    local rc=0
    "$PY" "$HERE/compare_ao.py" "$OUT" "$OUT/$1.prt" --glb "$GLB" --objects "$2" >"$OUT/$1.json" 2>/dev/null || rc=$?
    "$PY" - "$OUT/$1.json" "$1" "${2//\//_}" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
for name in [k for k in d if isinstance(d[k], dict)]:
    s = d[name]
    print(f"  {sys.argv[2]:>9} {name:>7}: {s['texels']} texels, mean prt - Cycles {s['mean_diff']:+.4f}, "
          f"rms over {s['smooth_texels']} smooth texels {s['smooth_rms_diff']:.4f} "
          f"(noise {s['smooth_expected_rms_noise']:.4f}): {'pass' if s['pass'] else 'FAIL'}")
EOF
    return $rc
}

# --double-sided off throughout: Blender marks every material doubleSided (backface culling
# off), and Cycles' AO and compare_ao.py (the GLB's triangles) know only the front sheets.
# --denoise off: the raw estimate, whose noise compare_ao.py's tolerance models.
"$BAKE" bake "$GLB" -o "$OUT/full.prt" --lightmap "$RES" --aux ao --samples "$PRT_SAMPLES" \
    --double-sided off --denoise off --quiet >"$OUT/full.log" 2>&1
echo "production.sh: prt-bake against Cycles' AO (must pass)"
compare full Ground,Wall/0
"$PY" - "$OUT/full.prt" <<'EOF'
# Under a uniform white sky (L_0 = 2 sqrt(pi)) the transfer's DC reconstructs the AO: the check
# above is then one of the stored transfer too, what a runtime lights.
import sys
from pathlib import Path
import numpy as np
sys.path.insert(0, str(Path.cwd() / "scripts" / "python"))
from prt import read_prt
f = read_prt(sys.argv[1])
valid = f.lightmap.valid
gap = np.abs(f.transfer[..., 0, 0] * 2 * np.sqrt(np.pi) - f.ao)[valid].max()
print(f"  the transfer's DC x 2 sqrt(pi) against the AO, {valid.sum()} texels: largest difference {gap:.1e}")
sys.exit(0 if gap < 1e-4 else 1)
EOF
for what in alpha normal; do
    "$PY" "$HERE/strip_glb.py" "$GLB" "$OUT/no_$what.glb" "$what"
    "$BAKE" bake "$OUT/no_$what.glb" -o "$OUT/no_$what.prt" --lightmap "$RES" --aux ao \
        --samples "$PRT_SAMPLES" --double-sided off --denoise off --quiet >"$OUT/no_$what.log" 2>&1
done
echo "production.sh: the cut-outs ignored (alphaMode stripped; the ground must fail)"
if compare no_alpha Ground; then echo "production.sh: the ground passes with the cards opaque" >&2; exit 1; fi
echo "production.sh: the normal map ignored (normalTexture stripped; the wall must fail)"
if compare no_normal Wall/0; then echo "production.sh: the wall passes without its normal map" >&2; exit 1; fi
texels=$(date +%s.%N)

for mode in on off; do
    "$BAKE" bake "$GLB" -o "$OUT/vertex_$mode.prt" --receivers Ground --instances "$mode" --aux ao \
        --samples "$PRT_SAMPLES" --double-sided off --quiet >"$OUT/vertex_$mode.log" 2>&1
done
grep -q "5 placements of 1 meshes traced as instances" "$OUT/vertex_on.log" ||
    { cat "$OUT/vertex_on.log"; echo "production.sh: the crates were not traced as instances" >&2; exit 1; }
"$PY" - "$OUT/vertex_on.prt" "$OUT/vertex_off.prt" <<'EOF'
# The payload's first V x (n^2 + 1) floats (transfer, then AO) after the 128-byte header; the
# receiver section after them names the scene's object count, which instancing changes.
import sys
import numpy as np
on, off = (open(p, "rb").read() for p in sys.argv[1:3])
v, order = np.frombuffer(on, "<u4", 1, 24)[0], np.frombuffer(on, "<u4", 1, 16)[0]
floats = int(v) * (int(order) ** 2 + 1)
a, b = (np.frombuffer(x, "<f4", floats, 128) for x in (on, off))
ao = a[-int(v):]
print(f"  vertex bake of the ground ({v} vertices), --instances on vs off: "
      f"{'bit for bit equal' if a.tobytes() == b.tobytes() else 'DIFFERENT'}, "
      f"largest difference {np.abs(a - b).max():.3g}; AO {ao.min():.3f}..{ao.max():.3f}")
sys.exit(0 if a.tobytes() == b.tobytes() and ao.min() < 0.5 else 1)
EOF
done_=$(date +%s.%N)
awk -v a="$started" -v b="$blender" -v c="$texels" -v d="$done_" 'BEGIN {
    printf "production.sh: Blender (scene, export, Cycles AO) %.1f s, texel bakes and comparisons %.1f s, vertex bakes %.1f s\n",
        b - a, c - b, d - c }'
