#!/usr/bin/env bash
# Exports the demo bake as .glb (grey and RGB transfer, with and without a rig's COLOR_0, and a
# lightmap bake with TEXCOORD_1 and its relit lightmap embedded, AO per vertex and per texel) and
# runs the Khronos glTF-Validator on the files: any error fails. The validator (npm package
# `gltf-validator`) is installed into target/node on first use.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
NODE_DIR=target/node
OUT=target/gltf-validate
if [ ! -d "$NODE_DIR/node_modules/gltf-validator" ]; then
    command -v npm >/dev/null || { echo "validate.sh: npm is missing (scripts/install-deps.sh installs it)" >&2; exit 2; }
    mkdir -p "$NODE_DIR"
    npm install --silent --no-audit --no-fund --prefix "$NODE_DIR" gltf-validator@2.0.0-dev.3.10
fi
cargo build --release --workspace # make build's features: -p prt-baker alone resolves them anew and rebuilds every dependency
BAKE=target/release/prt-bake
mkdir -p "$OUT"
$BAKE bake scenes/torus/torus.scene -o "$OUT/torus.prt" --samples 16 --order 3 --quiet
$BAKE export "$OUT/torus.prt" --scene scenes/torus/torus.scene --gltf "$OUT/torus.glb"
$BAKE bake scenes/cornell/cornell.scene -o "$OUT/cornell.prt" --samples 16 --mode interreflected --quiet
$BAKE export "$OUT/cornell.prt" --scene scenes/cornell/cornell.scene --gltf "$OUT/cornell.glb" \
    --lights viewer/src/default-rig.toml
# A lightmap (texel) bake: TEXCOORD_1 = the atlas's UVs, and with a rig the relit lightmap.
$BAKE bake scenes/cornell/cornell.scene -o "$OUT/cornell-lm.prt" --lightmap 64 --samples 16 --quiet
$BAKE export "$OUT/cornell-lm.prt" --scene scenes/cornell/cornell.scene --glb "$OUT/cornell-lm.glb" \
    --lights viewer/src/default-rig.toml
# AO: a texel bake's as occlusionTexture on TEXCOORD_1 beside the relit lightmap, a vertex
# bake's as the _AO attribute.
$BAKE bake scenes/cornell/cornell.scene -o "$OUT/cornell-lm-ao.prt" --lightmap 64 --samples 16 --aux ao --quiet
$BAKE export "$OUT/cornell-lm-ao.prt" --scene scenes/cornell/cornell.scene --glb "$OUT/cornell-lm-ao.glb" \
    --lights viewer/src/default-rig.toml
$BAKE bake scenes/torus/torus.scene -o "$OUT/torus-ao.prt" --samples 16 --order 3 --aux ao --quiet
$BAKE export "$OUT/torus-ao.prt" --scene scenes/torus/torus.scene --glb "$OUT/torus-ao.glb"
# The texel bake without a rig: plain PBR materials, what a re-bake reads (the rig's export
# adds the relit lightmap beside the base colour, in extras.prt_lightmap).
$BAKE export "$OUT/cornell-lm.prt" --scene scenes/cornell/cornell.scene --glb "$OUT/cornell-lm-plain.glb"
# The exported file read back as a scene: the round trip.
$BAKE bake "$OUT/torus.glb" -o "$OUT/torus-from-glb.prt" --samples 16 --order 3 --quiet
$BAKE export "$OUT/torus-from-glb.prt" --scene "$OUT/torus.glb" --gltf "$OUT/torus-again.glb"
# The texel bake's glb as a scene: its TEXCOORD_1 is the atlas of a new texel bake.
$BAKE bake "$OUT/cornell-lm-plain.glb" -o "$OUT/cornell-lm-from-glb.prt" --lightmap 64 --samples 16 --quiet
$BAKE export "$OUT/cornell-lm-from-glb.prt" --scene "$OUT/cornell-lm-plain.glb" --glb "$OUT/cornell-lm-again.glb"
# A CPCA-compressed bake: _PRT_CLUSTER and _PRT_W0 per vertex, the clusters in the buffer.
$BAKE bake scenes/cornell/cornell.scene -o "$OUT/cornell-cpca.prt" --samples 16 --mode interreflected \
    --clusters 16 --pcs 4 --quiet
$BAKE export "$OUT/cornell-cpca.prt" --scene scenes/cornell/cornell.scene --glb "$OUT/cornell-cpca.glb" \
    --lights viewer/src/default-rig.toml
# A compressed transfer-matrix (glossy) bake: matrices in the clusters, each material's lobe in
# extras.prt_glossy.
$BAKE bake scenes/torus/glossy.scene -o "$OUT/glossy-cpca.prt" --transfer matrix --order 2 --samples 16 \
    --clusters 16 --pcs 4 --quiet
$BAKE export "$OUT/glossy-cpca.prt" --scene scenes/torus/glossy.scene --glb "$OUT/glossy-cpca.glb" \
    --lights viewer/src/default-rig.toml
# The production courtyard (cut-out foliage cards, a normal-mapped wall, every material
# doubleSided), per vertex and per texel with a rig, and the cut-out card: the exports keep the
# source's materials (docs/reference/gltf.md, "Materials"), checked field by field.
COURTYARD=scenes/production/courtyard.glb
$BAKE bake $COURTYARD -o "$OUT/courtyard.prt" --samples 16 --quiet
$BAKE export "$OUT/courtyard.prt" --scene $COURTYARD --glb "$OUT/courtyard.glb" --lights viewer/src/default-rig.toml
$BAKE bake $COURTYARD -o "$OUT/courtyard-lm.prt" --lightmap 64 --samples 16 --quiet 2>/dev/null
$BAKE export "$OUT/courtyard-lm.prt" --scene $COURTYARD --glb "$OUT/courtyard-lm.glb" --lights viewer/src/default-rig.toml
$BAKE bake scenes/cutout/card.glb -o "$OUT/card.prt" --samples 16 --quiet
$BAKE export "$OUT/card.prt" --scene scenes/cutout/card.glb --glb "$OUT/card.glb"
# A skinned glTF's LDPRT bake written back into it: skin, joints, weights, inverse bind
# matrices and the animation kept, the lobes as _LDPRT_* attributes.
SKINNED=scenes/tube/tube-skinned.glb
$BAKE bake $SKINNED -o "$OUT/tube-skinned.ldprt" --transfer ldprt --lobes 3 --samples 16 --quiet
$BAKE export "$OUT/tube-skinned.ldprt" --scene $SKINNED --glb "$OUT/tube-skinned-ldprt.glb"
# The Blender-made walking character (scripts/blender/make_walker.py), as committed and exported.
WALKER=scenes/cornell/walker.glb
$BAKE bake $WALKER -o "$OUT/walker.ldprt" --transfer ldprt --lobes 3 --samples 16 --quiet
$BAKE export "$OUT/walker.ldprt" --scene $WALKER --glb "$OUT/walker-ldprt.glb"
node scripts/gltf/materials.mjs $COURTYARD "$OUT/courtyard.glb" "$OUT/courtyard-lm.glb"
node scripts/gltf/materials.mjs scenes/cutout/card.glb "$OUT/card.glb"
node scripts/gltf/validate.mjs "$NODE_DIR/node_modules" "$OUT/torus.glb" "$OUT/cornell.glb" "$OUT/torus-again.glb" \
    "$OUT/cornell-lm.glb" "$OUT/cornell-lm-again.glb" "$OUT/cornell-lm-ao.glb" "$OUT/torus-ao.glb" \
    "$OUT/cornell-lm-plain.glb" "$OUT/cornell-cpca.glb" "$OUT/glossy-cpca.glb" \
    "$OUT/courtyard.glb" "$OUT/courtyard-lm.glb" "$OUT/card.glb" "$OUT/tube-skinned-ldprt.glb" \
    $WALKER "$OUT/walker-ldprt.glb"
