# Sourced by run.sh and serve.sh: installs npm packages at pinned versions into target/node
# (never globally), unless that folder already holds exactly those versions.
# Usage: node_deps PACKAGE@VERSION...
NODE_DIR=target/node
node_deps() {
    command -v npm >/dev/null || { echo "browser: npm is missing (scripts/install-deps.sh installs it)" >&2; exit 2; }
    local spec missing=0
    for spec in "$@"; do
        local name=${spec%@*} version=${spec##*@}
        if ! [ -f "$NODE_DIR/node_modules/$name/package.json" ] ||
            ! node -e "process.exit(require(process.argv[1]).version === process.argv[2] ? 0 : 1)" \
                "$PWD/$NODE_DIR/node_modules/$name/package.json" "$version"; then
            missing=1
        fi
    done
    if [ "$missing" = 1 ]; then
        mkdir -p "$NODE_DIR"
        npm install --silent --no-audit --no-fund --save-exact --prefix "$NODE_DIR" "$@"
    fi
}
THREE_VERSION=0.187.0
