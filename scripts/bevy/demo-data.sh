#!/usr/bin/env bash
# make bevy-demo-data: the Cornell room's texel bake that the day_night example opens when
# given no --scene: target/bevy/demo/cornell-lm.glb and its export --exr folder.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
BAKE=target/release/prt-bake
OUT=target/bevy/demo
mkdir -p "$OUT"
$BAKE bake scenes/cornell/cornell.scene -o "$OUT/cornell-lm.prt" --lightmap 256 --mode interreflected --samples 256
$BAKE export "$OUT/cornell-lm.prt" --scene scenes/cornell/cornell.scene --glb "$OUT/cornell-lm.glb" --lights viewer/src/default-rig.toml
$BAKE export "$OUT/cornell-lm.prt" --scene scenes/cornell/cornell.scene --exr "$OUT/cornell-lm-exr" --exr-type f16
