#!/usr/bin/env bash
# Checks that embree-sys (and the baker on top of it) still compiles against the Embree 4
# headers, on a Debian 12 machine that only has Embree 3 installed.
#
# Embree 4 (Debian 13 "trixie", libembree-dev 4.3) cannot run on Debian 12 (its libraries need
# a newer glibc), but its headers are enough for `cargo check`. This script
#   1. downloads trixie's libembree-dev .deb with a private apt configuration held in a
#      temporary folder (the system's /etc/apt, /var/lib/apt/lists and /var/cache/apt are not
#      touched, and the script verifies that),
#   2. unpacks it with `dpkg -x` (nothing is installed),
#   3. runs `cargo check` on embree-sys (all targets) and prt-baker (its library, binary and
#      benches: the targets that use embree-sys; its tests reach Embree only through them) with
#      EMBREE_INCLUDE_DIR pointing at the unpacked headers, in target/embree4-check,
#   4. verifies that the build script really used those headers: major=4 in its metadata and
#      Embree-4-only types (RTCOccludedArguments) in the generated bindings.
#
# If the .deb cannot be obtained (no apt-get, not root, no network, apt fails), it prints one
# line starting with `check-embree4: skipped:` and exits 0. Any later failure (cargo check,
# verification) exits non-zero. Needs root (apt-get download with a private state folder).
#
# Usage: scripts/check-embree4.sh   (from anywhere; it works from the repository root)
set -euo pipefail

SCRIPT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO_ROOT="$(cd "$SCRIPT_DIR/.." && pwd)"
KEYRING=/usr/share/keyrings/debian-archive-keyring.gpg
SUITE=trixie
TARGET_DIR=target/embree4-check

skip() {
    echo "check-embree4: skipped: $*"
    exit 0
}
fail() {
    echo "check-embree4: FAILED: $*" >&2
    exit 1
}

command -v apt-get >/dev/null 2>&1 || skip "apt-get not found (not a Debian-like system)"
command -v dpkg >/dev/null 2>&1 || skip "dpkg not found"
[ "$(id -u)" -eq 0 ] || skip "must run as root (apt-get download with a private apt state)"
command -v cargo >/dev/null 2>&1 || fail "cargo not found"
[ -r "$KEYRING" ] || skip "$KEYRING not found (install debian-archive-keyring)"

T="$(mktemp -d "${TMPDIR:-/tmp}/check-embree4.XXXXXX")"
trap 'rm -rf "$T"' EXIT

# A fingerprint of the system's apt configuration and state, compared at the end.
apt_state() {
    find /etc/apt /var/lib/apt/lists /var/cache/apt -xdev \
        -printf '%p %y %s %T@ %m\n' 2>/dev/null | LC_ALL=C sort | sha256sum
}
STATE_BEFORE="$(apt_state)"

echo "deb [signed-by=$KEYRING] http://deb.debian.org/debian $SUITE main" >"$T/sources.list"
mkdir -p "$T/lists/partial" "$T/cache/archives/partial" "$T/debs" "$T/root"
APT_OPTS=(
    -o "Dir::Etc::SourceList=$T/sources.list"
    -o "Dir::Etc::SourceParts=/nonexistent"
    -o "Dir::State::Lists=$T/lists"
    -o "Dir::Cache=$T/cache"
    -o "Debug::NoLocking=1"
    # Download as root: the temporary folder (mode 0700) is not readable by the `_apt`
    # sandbox user, which apt would otherwise warn about and fall back from anyway.
    -o "APT::Sandbox::User=root"
    -o "Acquire::Retries=0"
    -o "Acquire::http::Timeout=30"
    -o "Acquire::Languages=none"
)

# The most telling line of an apt log, for the one-line skip reason: the first failed fetch,
# else the first error, else the last warning or line.
apt_reason() {
    local line
    line="$(grep -m 1 -E '^(W|E): Failed to fetch' "$1" || true)"
    [ -n "$line" ] || line="$(grep -m 1 -E '^(E|Err):' "$1" || true)"
    [ -n "$line" ] || line="$(grep -E '^W:' "$1" | tail -n 1 || true)"
    [ -n "$line" ] || line="$(tail -n 1 "$1" || true)"
    echo "$line" | tr -s '[:space:]' ' ' | sed 's/ $//'
}

echo "check-embree4: downloading libembree-dev from Debian $SUITE into $T"
if ! apt-get -q "${APT_OPTS[@]}" update >"$T/update.log" 2>&1; then
    skip "apt-get update for $SUITE failed (no network?): $(apt_reason "$T/update.log")"
fi
# apt-get update exits 0 when it cannot fetch an index (it only warns): treat that as failed.
if grep -qE '^(E:|Err:|W: Failed to fetch|W: Some index files failed)' "$T/update.log"; then
    skip "apt-get update for $SUITE could not fetch the index (no network?): $(apt_reason "$T/update.log")"
fi
if grep -qE '^W:' "$T/update.log"; then
    echo "check-embree4: note: apt-get update warned:" >&2
    grep -E '^W:' "$T/update.log" >&2
fi
if ! (cd "$T/debs" && apt-get -q "${APT_OPTS[@]}" download libembree-dev) >"$T/download.log" 2>&1; then
    skip "apt-get download libembree-dev failed: $(apt_reason "$T/download.log")"
fi
if grep -qE '^W:' "$T/download.log"; then
    echo "check-embree4: note: apt-get download warned:" >&2
    grep -E '^W:' "$T/download.log" >&2
fi
shopt -s nullglob
DEBS=("$T"/debs/libembree-dev_*.deb)
shopt -u nullglob
[ "${#DEBS[@]}" -eq 1 ] || skip "apt-get download produced no libembree-dev .deb"

dpkg -x "${DEBS[0]}" "$T/root" || fail "dpkg -x ${DEBS[0]} failed"
INCLUDE="$T/root/usr/include"
CONFIG="$INCLUDE/embree4/rtcore_config.h"
[ -f "$CONFIG" ] && [ -f "$INCLUDE/embree4/rtcore.h" ] ||
    fail "$(basename "${DEBS[0]}") has no usr/include/embree4/rtcore.h"
version_part() {
    sed -n "s/^#define RTC_VERSION_$1 \\+\\([0-9]\\+\\).*/\\1/p" "$CONFIG" | head -n 1
}
VERSION="$(version_part MAJOR).$(version_part MINOR).$(version_part PATCH)"
[ "$(version_part MAJOR)" = 4 ] || fail "$CONFIG declares Embree $VERSION, not 4.x"
echo "check-embree4: $(basename "${DEBS[0]}"): Embree $VERSION headers"

STATE_AFTER="$(apt_state)"
[ "$STATE_BEFORE" = "$STATE_AFTER" ] ||
    fail "the system's apt configuration or state changed (/etc/apt, /var/lib/apt/lists, /var/cache/apt; or another apt process ran meanwhile)"

cd "$REPO_ROOT"
for targets in "-p embree-sys --all-targets" "-p prt-baker --lib --bins --benches"; do
    echo "check-embree4: cargo check $targets --target-dir $TARGET_DIR"
    # shellcheck disable=SC2086 # $targets is a list of arguments
    EMBREE_INCLUDE_DIR="$INCLUDE" cargo check $targets --target-dir "$TARGET_DIR" ||
        fail "cargo check $targets against the Embree $VERSION headers failed"
done

# The build script's recorded output for this run names the temporary include folder, so a
# stale output from an earlier run (Embree 3, or another folder) cannot pass.
OUTPUT=""
for candidate in "$TARGET_DIR"/debug/build/embree-sys-*/output; do
    if grep -qxF "cargo::metadata=include=$INCLUDE/embree4" "$candidate"; then
        OUTPUT="$candidate"
    fi
done
[ -n "$OUTPUT" ] || fail "no embree-sys build-script output under $TARGET_DIR names $INCLUDE/embree4"
grep -qxF "cargo::metadata=major=4" "$OUTPUT" || fail "$OUTPUT does not record major=4"
grep -qxF "cargo::rustc-cfg=embree_v4" "$OUTPUT" || fail "$OUTPUT does not set cfg(embree_v4)"
grep -qxF "cargo::rustc-link-lib=dylib=embree4" "$OUTPUT" || fail "$OUTPUT does not link embree4"
BINDINGS="$(dirname "$OUTPUT")/out/bindings.rs"
[ -f "$BINDINGS" ] || fail "$BINDINGS not found"
# (rtcInitOccludedArguments itself is a static inline function: bindgen emits no binding.)
for symbol in RTCOccludedArguments RTCIntersectArguments rtcForwardOccluded1; do
    grep -q "\\b$symbol\\b" "$BINDINGS" || fail "$BINDINGS lacks the Embree 4 symbol $symbol"
done

echo "check-embree4: ok (Embree $VERSION headers)"
