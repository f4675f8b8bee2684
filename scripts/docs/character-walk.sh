#!/usr/bin/env bash
# docs/images/character-walk.png: the bpy-made walker (scenes/cornell/walker.glb) at four
# times of its walk across the Cornell room, lit by the room's probes at its position and
# self-shadowed by its LDPRT bake; prt-view headless screenshots joined side by side
# (docs/guides/characters.md, "A character walking through the room"). About 10 s after a
# release build. Environment: OUT (target/character-walk), IMAGE (docs/images/character-walk.png).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
OUT="${OUT:-target/character-walk}"
IMAGE="${IMAGE:-docs/images/character-walk.png}"
BAKE=target/release/prt-bake
VIEW=target/release/prt-view
nice -n 10 cargo build --release -p prt-baker -p prt-viewer --example side_by_side
mkdir -p "$OUT"
# A sun through the open front of the room and a sky.
cp scenes/cornell/room-rig.toml "$OUT/rig.toml"
ROOM=scenes/cornell/cornell.scene
WALKER=scenes/cornell/walker.glb
$BAKE bake $ROOM -o "$OUT/room.prt" --order 4 --mode interreflected --samples 512 --quiet
$BAKE bake $ROOM -o "$OUT/probes.prt" --probes grid:6,6,6 --order 4 --mode interreflected --samples 1024 --quiet
$BAKE bake $WALKER -o "$OUT/walker.ldprt" --transfer ldprt --lobes 3 --order 4 --samples 512 --quiet
frames=()
for t in 0.3 1.4 2.6 3.7; do
    $VIEW $ROOM "$OUT/room.prt" --probes "$OUT/probes.prt" --hide-probes \
        --character $WALKER --character-ldprt "$OUT/walker.ldprt" --pose "walk@$t" \
        --lights "$OUT/rig.toml" --camera 0,-2.6,0.8,90,-8 --size 320x300 \
        --headless --screenshot "$OUT/walk-$t.png" 2>/dev/null
    frames+=("$OUT/walk-$t.png")
done
target/release/examples/side_by_side "$IMAGE" "${frames[@]}"
echo "character-walk.sh: wrote $IMAGE"
