#!/usr/bin/env bash
# The browser test of runtime/three/prt.js (make browser, part of make test): Debian's
# chromium (scripts/install-deps.sh installs it) driven by playwright-core renders prt-bake's
# .glb exports with three.js, as exported and relit by prt.js, and compares them
# (scripts/browser/test.mjs says how). playwright-core and three are npm packages installed
# into target/node at pinned versions, as scripts/gltf/validate.sh installs gltf-validator;
# the page gets three.js from there through a static server on 127.0.0.1, and no other
# address is reached. Also checks prt.js's SH rotation against prt-bake light --up, and
# compiles docs/reference/gltf.md's GLSL ES snippets with glslangValidator.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
# shellcheck source=scripts/browser/node-deps.sh
. scripts/browser/node-deps.sh
OUT=target/browser
PLAYWRIGHT_VERSION=1.65.1
[ -x /usr/bin/chromium ] || { echo "browser: /usr/bin/chromium is missing (scripts/install-deps.sh installs it)" >&2; exit 2; }
node_deps "three@$THREE_VERSION" "playwright-core@$PLAYWRIGHT_VERSION"
cargo build --release --workspace # make build's features: -p prt-baker alone resolves them anew and rebuilds every dependency
rm -rf "$OUT"
mkdir -p "$OUT"
command -v glslangValidator >/dev/null || { echo "browser: glslangValidator is missing (scripts/install-deps.sh installs glslang-tools)" >&2; exit 2; }
node scripts/browser/glsl-snippets.mjs docs/reference/gltf.md "$OUT/glsl"
node scripts/browser/sh-test.mjs target/release/prt-bake "$OUT"
node scripts/browser/probe-test.mjs target/release/prt-bake "$OUT"
# Moving occluders: occluders.js's occludedTransfer against relight --occluder (docs/guides/occluders.md).
node scripts/browser/occluder-test.mjs target/release/prt-bake "$OUT"
# ... and in Chromium: the room's .glb relit by prt.js, darkened by occluders.js for two movers.
node scripts/browser/occluder-render.mjs "$NODE_DIR/node_modules" target/release/prt-bake "$OUT"
# A rigid object moving through the Cornell room's probes, lit by prt.js in Chromium, against
# relight at probes baked exactly at its positions (docs/guides/probes.md).
node scripts/browser/probe-move.mjs "$NODE_DIR/node_modules" target/release/prt-bake "$OUT"
node scripts/browser/test.mjs "$NODE_DIR/node_modules" target/release/prt-bake "$OUT"
# LDPRT on a SkinnedMesh: the skinned tube posed by three's AnimationMixer and lit by ldprt.js,
# against relight --pose at 0, 0.5 and 1 s (docs/guides/characters.md).
node scripts/browser/ldprt-skinned.mjs "$NODE_DIR/node_modules" target/release/prt-bake "$OUT"
# Cut-outs, textures and two-sided sheets: the cut-out card against its geometry twin, and the
# courtyard relit by prt.js against three.js's own render of its export (docs/reference/gltf.md).
node scripts/browser/cutouts.mjs "$NODE_DIR/node_modules" target/release/prt-bake "$OUT"
# Glossy PRT: a CPCA-compressed transfer-matrix export relit by prt.js against
# prt-bake relight --view from three camera positions.
node scripts/browser/glossy.mjs "$NODE_DIR/node_modules" target/release/prt-bake "$OUT"
