#!/usr/bin/env bash
# Installs the Debian packages the build and the tests need, only those missing:
#   libembree-dev       Embree (3.13 on Debian 12, 4.3 on Debian 13): headers and library
#   libclang-dev        libclang, which bindgen loads to read Embree's headers
#   mesa-vulkan-drivers Mesa's Vulkan drivers, lavapipe among them: prt-view and its tests
#                       render on the CPU where there is no GPU
#   libvulkan1          the Vulkan loader
#   xvfb xauth          a virtual X server, for the test of prt-view's window (xvfb-run)
#   libx11-6 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0
#                       the X11 libraries winit loads at run time
#   npm (with nodejs)   the Khronos glTF-Validator of `make interop`; only if no npm is on
#                       PATH (a NodeSource or nvm install is kept)
#   python3-venv        the venvs of the reference check and the Python reader's test
#   slurm-wlm munge     Slurm 22.05 (slurmctld, slurmd, sbatch) and its authentication daemon:
#                       the sharded-bake test starts a single-node cluster of its own
#                       (scripts/slurm/test-cluster.sh) on its own ports and munge socket, so
#                       it does not need or disturb the packages' own services
#   chromium            the browser test of the web runtime (scripts/browser/run.sh), headless
#                       with SwiftShader: no GPU or display needed
#   glslang-tools       glslangValidator, which compiles docs/reference/gltf.md's GLSL ES snippets
# make bevy (runtime/bevy) needs nothing more: it renders headless through the same Vulkan
# loader and lavapipe, and its window (--features window) loads the X11 libraries above.
# The Rust toolchain itself is expected (rustup); python3 for the reference check.
set -euo pipefail

packages=(libembree-dev libclang-dev mesa-vulkan-drivers libvulkan1 xvfb xauth
    libx11-6 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0 slurm-wlm munge
    chromium glslang-tools)
command -v npm >/dev/null 2>&1 || packages+=(npm)
packages+=(python3-venv)
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
