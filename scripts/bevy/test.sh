#!/usr/bin/env bash
# make bevy: the Bevy plugin's tests (runtime/bevy; docs/guides/bevy.md). Its own workspace,
# built into target/bevy with its own Cargo.lock. The day_night example renders prt-bake's
# exports headless (Vulkan on Mesa's lavapipe) relit by bevy_prt and as exported (COLOR_0, or
# the relit lightmap through Bevy's own Lightmap), at a rig and with the rig turned 90° (the
# turned render against an export of the turned rig), and requires ≥ 99 % of the lit pixels
# within 2 codes; then times PRT against Bevy's plain Lightmap on the Cornell room.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
BAKE=target/release/prt-bake
OUT=target/bevy/test
export CARGO_TARGET_DIR=target/bevy
MANIFEST=runtime/bevy/Cargo.toml
EXAMPLE=target/bevy/release/examples/day_night
# Without a display, Vulkan's loader asks libwayland for a socket: a private empty folder
# answers it quietly (as make demo does).
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then XDG_RUNTIME_DIR=$(mktemp -d); export XDG_RUNTIME_DIR; fi
export RUST_LOG=${RUST_LOG:-warn}

started=$(date +%s)
cargo fmt --manifest-path "$MANIFEST" --check
# One release build of every target, the interactive example's window (winit, X11) included,
# with Clippy as the plugin's compiler (what `cargo clippy` does, but building, not only
# checking): Bevy's crates are compiled once, not checked once more in the dev profile
# (docs/explanation/performance.md). The wrapper and its arguments (CLIPPY_ARGS, the channel
# by which `cargo clippy -- -D warnings` hands them to clippy-driver) touch the plugin's
# crate alone, so Bevy's crates are the very build that the guide's plain
# `cargo run --release --features window` reuses. Every cargo call below shares these
# settings, so none builds again.
RUSTC_WORKSPACE_WRAPPER=$(command -v clippy-driver) ||
    { echo "bevy: clippy-driver not found (rustup component add clippy)" >&2; exit 1; }
export RUSTC_WORKSPACE_WRAPPER CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
# CLIPPY_ARGS is Clippy's internal channel, not a documented interface: should a toolchain
# change it, the build below would still lint but no longer fail on a warning. So a file
# with one warning (clippy::ptr_arg) must fail through the same wrapper and arguments first.
canary=$(mktemp -d)
failed_on_it=no
log=$(printf 'pub fn len(v: &Vec<u8>) -> usize {\n    v.len()\n}\n' |
    "$RUSTC_WORKSPACE_WRAPPER" rustc - --crate-name canary --crate-type lib --edition 2021 \
        --emit=metadata --out-dir "$canary" 2>&1) || failed_on_it=yes
rm -rf "$canary"
if [ "$failed_on_it" = no ] || ! grep -q 'clippy::ptr_arg' <<<"$log"; then
    echo "bevy: clippy-driver with CLIPPY_ARGS=$CLIPPY_ARGS did not fail on clippy::ptr_arg:" >&2
    echo "$log" >&2
    echo "bevy: this toolchain's Clippy takes its arguments another way: update this script" >&2
    exit 1
fi
FEATURES=(--release --features window)
cargo build --manifest-path "$MANIFEST" "${FEATURES[@]}" --all-targets
cargo test --manifest-path "$MANIFEST" "${FEATURES[@]}" --lib
echo "bevy: built, linted and unit-tested in $(( $(date +%s) - started )) s"

rm -rf "$OUT"
mkdir -p "$OUT"
# The rig of the browser test and its twin turned 90° about the z-up world's +z (which is
# glTF's +Y, the axis day_night --turn turns about).
rig() {
    local turn=$1 file=$2
    python3 - "$turn" "$file" <<'PY'
import math, sys
t = math.radians(float(sys.argv[1]))
def turn(v):
    x, y, z = v
    return [x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t), z]
sun = [math.sin(1.134) * math.cos(0.524), math.sin(1.134) * math.sin(0.524), math.cos(1.134)]
d = lambda v: "[" + ", ".join(f"{c:.15f}" for c in turn(v)) + "]"
open(sys.argv[2], "w").write(f"""[[light]]
kind = "sun"
direction = {d(sun)}
color = [1.0, 0.92, 0.8]
intensity = 2.5

[[light]]
kind = "hemisphere"
direction = {d([0, 0, 1])}
color = [0.35, 0.4, 0.5]
ground_color = [0.05, 0.045, 0.04]
""")
PY
}
rig 0 "$OUT/rig.toml"
rig 90 "$OUT/rig-turned.toml"

torus=scenes/torus/torus.scene
cornell=scenes/cornell/cornell.scene
$BAKE bake "$torus" -o "$OUT/torus.prt" --samples 64 --order 3 --quiet
$BAKE bake "$cornell" -o "$OUT/cornell-lm.prt" --samples 64 --lightmap 128 --quiet
for case in torus:$torus cornell-lm:$cornell; do
    name=${case%%:*} scene=${case#*:}
    $BAKE export "$OUT/$name.prt" --scene "$scene" --glb "$OUT/$name.glb" --lights "$OUT/rig.toml" >/dev/null
    $BAKE export "$OUT/$name.prt" --scene "$scene" --glb "$OUT/$name-turned.glb" --lights "$OUT/rig-turned.toml" >/dev/null
done
$BAKE export "$OUT/cornell-lm.prt" --scene "$cornell" --exr "$OUT/cornell-lm-exr" --exr-type f16 >/dev/null

failed=0
check() {
    local label=$1
    shift
    if "$EXAMPLE" "$@" | sed "s/^/bevy: $label: /"; then :; else failed=$((failed + 1)); fi
}
for name in torus cornell-lm; do
    exr=()
    view=0.15,0.2,1
    [ "$name" = torus ] && view=0.6,0.9,1
    [ "$name" = cornell-lm ] && exr=(--exr "$OUT/cornell-lm-exr")
    check "$name rig" --scene "$OUT/$name.glb" "${exr[@]}" --lights "$OUT/rig.toml" --view "$view" \
        --screenshot "$OUT/$name.png" --compare
    check "$name turned 90°" --scene "$OUT/$name.glb" "${exr[@]}" --lights "$OUT/rig.toml" --turn 90 --view "$view" \
        --screenshot "$OUT/$name-turned.png" --compare "$OUT/$name-turned.glb"
done

# Bevy's specular over T·L (--specular, a DirectionalLight per rig sun, roughness 0.35,
# reflectance 0.5), per vertex and per texel: away from the highlight the render is T·L alone,
# everywhere it is T·L plus Bevy's own StandardMaterial specular (black base colour) added in
# linear light, within 2 codes; turning the light 90° moves the highlight.
for name in torus cornell-lm; do
    exr=()
    view=0.15,0.2,1
    [ "$name" = torus ] && view=0.6,0.9,1
    [ "$name" = cornell-lm ] && exr=(--exr "$OUT/cornell-lm-exr")
    centres=()
    for turn in 0 90; do
        if result=$("$EXAMPLE" --scene "$OUT/$name.glb" "${exr[@]}" --lights "$OUT/rig.toml" --turn "$turn" \
            --view "$view" --specular --screenshot "$OUT/$name-specular-$turn.png" --compare); then :; else
            failed=$((failed + 1))
        fi
        echo "$result" | sed "s/^/bevy: $name specular, light turned $turn°: /"
        centres+=("$(echo "$result" | sed -n 's/.*centred at (\([0-9.]*\), \([0-9.]*\)).*/\1 \2/p')")
    done
    if ! python3 - "${centres[@]}" <<'PY'
import math, sys
(a, b), (c, d) = (map(float, s.split()) for s in sys.argv[1:3])
moved = math.hypot(c - a, d - b)
print(f"bevy: {'ok  ' if moved > 5 else 'FAIL'} the highlight moved {moved:.1f} pixels with the light")
sys.exit(0 if moved > 5 else 1)
PY
    then failed=$((failed + 1)); fi
done

# The other forms of vertex transfer, at the rig: RGB (the Cornell room interreflected, 12
# attributes), CPCA-compressed (64 clusters × 4 components, reconstructed on load) and
# --quantize 16 (normalized shorts times their scales).
$BAKE bake "$cornell" -o "$OUT/cornell-rgb.prt" --mode interreflected --samples 64 --quiet
$BAKE bake "$cornell" -o "$OUT/cornell-cpca.prt" --mode interreflected --clusters 64 --pcs 4 --samples 64 --quiet >/dev/null
$BAKE export "$OUT/cornell-rgb.prt" --scene "$cornell" --glb "$OUT/cornell-rgb.glb" --lights "$OUT/rig.toml" >/dev/null
$BAKE export "$OUT/cornell-cpca.prt" --scene "$cornell" --glb "$OUT/cornell-cpca.glb" --lights "$OUT/rig.toml" >/dev/null
$BAKE export "$OUT/torus.prt" --scene "$torus" --glb "$OUT/torus-q16.glb" --quantize 16 --lights "$OUT/rig.toml" >/dev/null
for name in cornell-rgb cornell-cpca torus-q16; do
    check "$name rig" --scene "$OUT/$name.glb" --lights "$OUT/rig.toml" --screenshot "$OUT/$name.png" --compare
done

# The asset loaders: every export above through Bevy's asset server equals load_export's read;
# bad files fail with a typed error naming them (tests/asset_loader.rs).
if BEVY_PRT_EXPORTS="$PWD/$OUT" cargo test --manifest-path "$MANIFEST" "${FEATURES[@]}" --test asset_loader 2>&1 |
    grep -E "^test |test result|panicked" | sed "s/^/bevy: asset loader: /"; then :; else failed=$((failed + 1)); fi

# A probe-lit object moving through the Cornell room: the ball of the browser test
# (scripts/browser/probe-move.mjs) baked alone, lit by bevy_prt from the room's 8×8×8
# interreflected probe grid at 3 positions, against relight --probes --at --turn from a probe
# baked exactly there.
python3 - "$OUT/ball.obj" <<'PY'
import math, sys
nu, nv, r = 12, 8, 0.12
n = [[math.sin(math.pi * j / nv) * math.cos(2 * math.pi * i / nu), math.sin(math.pi * j / nv) * math.sin(2 * math.pi * i / nu), math.cos(math.pi * j / nv)] for j in range(nv + 1) for i in range(nu + 1)]
lines = ["mtllib ball.mtl", "usemtl grey"] + [f"v {' '.join(f'{r * c:.6f}' for c in v)}" for v in n] + [f"vn {' '.join(f'{c:.6f}' for c in v)}" for v in n]
face = lambda *k: lines.append("f " + " ".join(f"{x + 1}//{x + 1}" for x in k))
for j in range(nv):
    for i in range(nu):
        a = j * (nu + 1) + i
        if j > 0: face(a, a + nu + 1, a + 1)
        if j < nv - 1: face(a + 1, a + nu + 1, a + nu + 2)
open(sys.argv[1], "w").write("\n".join(lines) + "\n")
PY
printf 'newmtl grey\nKd 0.8 0.8 0.8\n' > "$OUT/ball.mtl"
cp scenes/cornell/room-rig.toml "$OUT/probe-rig.toml"
probe_bake=(--order 3 --samples 1024 --mode interreflected --quiet)
$BAKE bake "$OUT/ball.obj" -o "$OUT/ball.prt" --order 3 --mode shadowed --samples 256 --quiet
$BAKE export "$OUT/ball.prt" --scene "$OUT/ball.obj" --glb "$OUT/ball.glb" >/dev/null
$BAKE bake "$cornell" -o "$OUT/grid.prt" --probes grid:8,8,8 "${probe_bake[@]}"
turn=0.2,0.9,0.4,70
k=0
for at in 0.35,0.4,0.2 -0.75,-0.5,0.8 0.75,-0.5,0.8; do
    IFS=, read -r x y z <<<"$at"
    box=$(python3 -c "print(','.join(f'{c:.4f}' for c in [$x-0.001,$y-0.001,$z-0.001,$x+0.001,$y+0.001,$z+0.001]))")
    $BAKE bake "$cornell" -o "$OUT/exact-$k.prt" --probes "grid:1,1,1:$box" "${probe_bake[@]}"
    $BAKE relight "$OUT/ball.obj" "$OUT/ball.prt" --lights "$OUT/probe-rig.toml" -o "$OUT/exact-$k.ply" \
        --probes "$OUT/exact-$k.prt" --at "$at" --turn "$turn" >/dev/null
    if target/bevy/release/examples/probe_move --object "$OUT/ball.glb" --probes "$OUT/grid.prt" \
        --lights "$OUT/probe-rig.toml" --at "$at" --turn "$turn" --radiance "$OUT/exact-$k.ply" \
        --screenshot "$OUT/probe-$k.png" | sed "s/^/bevy: probe at $at: /"; then :; else failed=$((failed + 1)); fi
    k=$((k + 1))
done

# Frame time: PRT per texel against Bevy's own Lightmap of the relit lightmap, same scene.
for mode in prt lightmap; do
    "$EXAMPLE" --scene "$OUT/cornell-lm.glb" --exr "$OUT/cornell-lm-exr" --bench "$mode" --size 512 --frames 200 | sed "s/^/bevy: /"
done
if [ "$failed" -ne 0 ]; then
    echo "bevy: FAILED ($failed comparison(s))"
    exit 1
fi
echo "bevy: every render matches ($(( $(date +%s) - started )) s)"
