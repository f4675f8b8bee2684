#!/usr/bin/env bash
# Interreflected transfer probes against Mitsuba 3 (scripts/mitsuba/probe_reference.py; issue
# 32, item 5): four probes in the Cornell room under a white sky, their order-3 band-limited
# irradiance at ±x, ±y, ±z against a path tracer on Mitsuba's rays (variant llvm_ad_rgb),
# 1 and 3 bounces; fresh references every run, about 15 s. Mitsuba, NumPy and libLLVM as for
# scripts/mitsuba/run.sh (the same venv, target/mitsuba-venv). Extra arguments go to the
# script (e.g. --paths 1048576 --samples 16384 for a closer look, --mode shadowed to watch it
# fail without interreflection).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
# shellcheck source=venv.sh
. "$HERE/venv.sh" llvm

cargo build --release --workspace # make build's features: -p prt-baker alone resolves them anew and rebuilds every dependency
exec "$VENV/bin/python" "$HERE/probe_reference.py" --prt-bake target/release/prt-bake "$@"
