#!/usr/bin/env bash
# The denoiser's share of a bake's CPU (not part of `make test`): runs one denoised bake on one
# thread under `perf record` and counts the samples whose call stack passes through the
# denoiser (`bake::denoise::`, its guides included) against the rest of the bake. A ratio
# within one process: steadier on a shared machine than timing the denoised and the raw bake
# one after the other (it still moves with the load; take the median of several runs).
#
#   scripts/bench/denoise_share.sh BAKE-ARGUMENTS...
#   scripts/bench/denoise_share.sh scenes/cornell/cornell.scene --lightmap 256 --order 3 --samples 64
#
# Prints: samples, denoiser samples, and the denoiser over the rest of the bake. Needs perf
# (Debian's linux-perf) and a release build with debug info (the workspace's release profile).
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
bake=${PRT_BAKE:-$root/target/release/prt-bake}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

perf record -q --call-graph dwarf,16384 -F 4000 -o "$work/perf.data" \
    "$bake" bake "$@" --threads 1 -o "$work/out.prt" >/dev/null 2>&1
perf script -i "$work/perf.data" -F ip,sym --no-inline 2>/dev/null | python3 -c '
import sys
stacks = [s for s in sys.stdin.read().split("\n\n") if s.strip()]
denoise = sum("denoise::" in s for s in stacks)
print(f"samples {len(stacks)}, denoiser {denoise}, "
      f"denoiser / rest of the bake {denoise / max(1, len(stacks) - denoise):.3f}")
'
