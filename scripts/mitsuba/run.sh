#!/usr/bin/env bash
# Interreflected bakes against Mitsuba 3 (scripts/mitsuba/mitsuba_reference.py; issue 22):
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
PYTHON="${PYTHON:-python3}"
VENV=target/mitsuba-venv
REQUIREMENTS="$HERE/requirements.txt"

has_deps() { "$1" -c 'import mitsuba, numpy' >/dev/null 2>&1; }

if ! has_deps "$VENV/bin/python"; then
    rm -rf "$VENV"
    if ! "$PYTHON" -m venv "$VENV" >/dev/null 2>&1 || [ ! -x "$VENV/bin/python" ]; then
        echo "run.sh: '$PYTHON -m venv' is unavailable (Debian: apt-get install python3-venv)" >&2
        exit 2
    fi
    echo "run.sh: installing Mitsuba 3 and NumPy into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$REQUIREMENTS"
fi

# Dr.Jit's LLVM backend loads libLLVM.so at run time.
if [ -z "${DRJIT_LIBLLVM_PATH:-}" ] && ! ldconfig -p 2>/dev/null | grep -q 'libLLVM'; then
    echo "run.sh: no libLLVM found; installing libllvm15 (Dr.Jit's LLVM backend needs it)"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    { $SUDO apt-get update -qq &&
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libllvm15 >/dev/null; } || {
        echo "run.sh: could not install libllvm15; install an LLVM shared library (apt-get" \
            "install libllvm15) or set DRJIT_LIBLLVM_PATH" >&2
        exit 2
    }
fi

cargo build --release -p prt-baker
exec "$VENV/bin/python" "$HERE/mitsuba_reference.py" --prt-bake target/release/prt-bake "$@"
