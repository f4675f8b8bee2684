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
PYTHON="${PYTHON:-python3}"
VENV="${MITSUBA_VENV:-target/mitsuba-venv}"

if ! "$VENV/bin/python" -c 'import mitsuba, numpy' >/dev/null 2>&1; then
    rm -rf "$VENV"
    if ! "$PYTHON" -m venv "$VENV" >/dev/null 2>&1 || [ ! -x "$VENV/bin/python" ]; then
        echo "probes.sh: '$PYTHON -m venv' is unavailable (Debian: apt-get install python3-venv)" >&2
        exit 2
    fi
    echo "probes.sh: installing Mitsuba 3 and NumPy into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$HERE/requirements.txt"
fi

# Dr.Jit's LLVM backend loads libLLVM.so at run time.
if [ -z "${DRJIT_LIBLLVM_PATH:-}" ] && ! ldconfig -p 2>/dev/null | grep -q 'libLLVM'; then
    echo "probes.sh: no libLLVM found; installing libllvm15 (Dr.Jit's LLVM backend needs it)"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    { $SUDO apt-get update -qq &&
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libllvm15 >/dev/null; } || {
        echo "probes.sh: could not install libllvm15; install an LLVM shared library (apt-get" \
            "install libllvm15) or set DRJIT_LIBLLVM_PATH" >&2
        exit 2
    }
fi

cargo build --release -p prt-baker
exec "$VENV/bin/python" "$HERE/probe_reference.py" --prt-bake target/release/prt-bake "$@"
