#!/usr/bin/env bash
# make web GLB=FILE.glb [PORT=8000]: the third command of the web round trip (README.md).
# Installs three.js into target/node (pinned, as make browser does), serves the repository's
# root on 127.0.0.1 with Python's static server, and prints the example page's address for
# FILE.glb. A .glb outside the repository is copied to target/web/ first, since the server
# only sees the repository. Ctrl-C stops the server.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
glb=${1:-}
port=${2:-8000}
[ -n "$glb" ] || { echo "web: give the .glb: make web GLB=out/scene.glb" >&2; exit 2; }
[ -f "$glb" ] || { echo "web: $glb: no such file" >&2; exit 3; }
[[ "$port" =~ ^[0-9]+$ ]] || { echo "web: PORT must be a number, got '$port'" >&2; exit 2; }
# shellcheck source=scripts/browser/node-deps.sh
. scripts/browser/node-deps.sh
node_deps "three@$THREE_VERSION"
root=$(pwd -P)
file=$(realpath "$glb")
case "$file" in
    "$root"/*) url_path=${file#"$root"} ;;
    *)
        mkdir -p target/web
        cp "$file" "target/web/$(basename "$file")"
        url_path=/target/web/$(basename "$file")
        ;;
esac
echo "web: open http://localhost:$port/runtime/three/example.html?glb=$url_path"
echo "web: (the light is the rig the .glb was exported with; &light=LIGHT.json gives another)"
exec python3 -m http.server "$port" --bind 127.0.0.1
