# Sourced by the Mitsuba checks (run.sh, subsurface.sh, probes.sh) from the repository root,
# with HERE set to this folder: makes the Mitsuba 3 venv (MITSUBA_VENV, default
# target/mitsuba-venv) if it lacks Mitsuba or NumPy, and, when `llvm` is passed, makes sure an
# LLVM shared library is there for Dr.Jit's LLVM backend. Sets VENV. Messages start with the
# sourcing script's name.
NAME="$(basename "$0")"
PYTHON="${PYTHON:-python3}"
VENV="${MITSUBA_VENV:-target/mitsuba-venv}"

if ! "$VENV/bin/python" -c 'import mitsuba, numpy' >/dev/null 2>&1; then
    rm -rf "$VENV"
    if ! "$PYTHON" -m venv "$VENV" >/dev/null 2>&1 || [ ! -x "$VENV/bin/python" ]; then
        echo "$NAME: '$PYTHON -m venv' is unavailable (Debian: apt-get install python3-venv)" >&2
        exit 2
    fi
    echo "$NAME: installing Mitsuba 3 and NumPy into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$HERE/requirements.txt"
fi

# Dr.Jit's LLVM backend loads libLLVM.so at run time.
if [ "${1:-}" = llvm ] && [ -z "${DRJIT_LIBLLVM_PATH:-}" ] &&
    ! ldconfig -p 2>/dev/null | grep -q 'libLLVM'; then
    echo "$NAME: no libLLVM found; installing libllvm15 (Dr.Jit's LLVM backend needs it)"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    { $SUDO apt-get update -qq &&
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libllvm15 >/dev/null; } || {
        echo "$NAME: could not install libllvm15; install an LLVM shared library (apt-get" \
            "install libllvm15) or set DRJIT_LIBLLVM_PATH" >&2
        exit 2
    }
fi
