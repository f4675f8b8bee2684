#!/usr/bin/env bash
# Installs the Debian packages the build needs, only those missing:
#   libembree-dev  Embree (3.13 on Debian 12, 4.3 on Debian 13): headers and library
#   libclang-dev   libclang, which bindgen loads to read Embree's headers
# The Rust toolchain itself is expected (rustup); python3 for the reference check.
set -euo pipefail

packages=(libembree-dev libclang-dev)
missing=()
for package in "${packages[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$package")
    fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

sudo=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
        sudo=sudo
    else
        echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2
        exit 1
    fi
fi
echo "install-deps: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
