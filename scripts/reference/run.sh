#!/usr/bin/env bash
# Runs the independent Python reference check of prt-bake (see README.md in this folder):
# installs numpy and scipy into target/reference-venv if they are missing there (falling back
# to `pip install --user` where `python3 -m venv` is unavailable), builds the release baker
# and runs independent_reference.py. Extra arguments go to the script.
#
# Usage: scripts/reference/run.sh [--vertices N] [--ref-samples N] [--sabotage KIND] ...
# Environment: PYTHON (default python3) picks the interpreter the environment is made from.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$HERE/../.."
PYTHON="${PYTHON:-python3}"
VENV=target/reference-venv
REQUIREMENTS="$HERE/requirements.txt"

has_deps() { "$1" -c 'import numpy, scipy' >/dev/null 2>&1; }

if has_deps "$VENV/bin/python"; then
    PY="$VENV/bin/python"
elif "$PYTHON" -m venv "$VENV" >/dev/null 2>&1 && [ -x "$VENV/bin/python" ]; then
    echo "run.sh: installing numpy and scipy into $VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$REQUIREMENTS"
    PY="$VENV/bin/python"
else
    rm -rf "$VENV" # a half-made environment (e.g. venv present but ensurepip missing)
    echo "run.sh: '$PYTHON -m venv' is unavailable; installing with pip --user instead"
    if ! has_deps "$PYTHON"; then
        "$PYTHON" -m pip install --quiet --disable-pip-version-check --user -r "$REQUIREMENTS" || {
            echo "run.sh: could not install numpy and scipy; install them yourself:" >&2
            echo "  $PYTHON -m pip install numpy scipy   (Debian: apt-get install python3-venv," \
                "or python3-numpy python3-scipy)" >&2
            exit 2
        }
    fi
    PY="$PYTHON"
fi

cargo build --release --workspace # make build's features: -p prt-baker alone resolves them anew and rebuilds every dependency
exec "$PY" "$HERE/independent_reference.py" --prt-bake target/release/prt-bake "$@"
