#!/usr/bin/env bash
# Interreflected bakes against Mitsuba 3 (scripts/mitsuba/mitsuba_reference.py):
# installs Mitsuba 3 and NumPy from PyPI into target/mitsuba-venv if they are missing there,
# builds the release baker and runs the comparison. Extra arguments go to the script.
#
# Mitsuba's llvm_ad_rgb variant needs an LLVM shared library at run time (Debian 12:
# libllvm15, which mesa-vulkan-drivers from scripts/install-deps.sh pulls in; installed here
# with apt-get when no libLLVM is found). DRJIT_LIBLLVM_PATH picks another one.
#
# Usage: scripts/mitsuba/run.sh [--paths N] [--points N] [--only cornell|room] ...
# Environment: PYTHON (default python3) picks the interpreter the environment is made from.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
# shellcheck source=venv.sh
. "$HERE/venv.sh" llvm

cargo build --release --workspace # make build's features: -p prt-baker alone resolves them anew and rebuilds every dependency
exec "$VENV/bin/python" "$HERE/mitsuba_reference.py" --prt-bake target/release/prt-bake "$@"
