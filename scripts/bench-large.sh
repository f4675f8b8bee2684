#!/usr/bin/env bash
# The large-scene benchmark (not part of `make test`): a generated terrain of about a
# million triangles with its own lightmap UVs (scripts/bench/large_scene.py), baked as a 2048²
# interreflected lightmap whole and in N shards run one after the other, then merged and
# compared byte for byte with the whole bake. Prints wall time, peak memory (/usr/bin/time -v)
# the bake's ray rate and CPU time per run, and the raw Embree rate of the same rays
# (baker/benches/large.rs). docs/explanation/performance.md records the figures.
#
#   scripts/bench-large.sh [N]        (default 4 shards)
#   scripts/bench-large.sh --scale    how texel bakes scale: 1 M and 4 M triangles ×
#                                     2048² and 4096², shadowed and interreflected, against the
#                                     vertex bake and raw Embree, and the staged shard pipeline
#                                     for N = 2 and 4 (scripts/bench/lightmap_scale.sh, whose
#                                     SCALE_* variables choose sizes and counts; `make bench-large`)
#
# Environment: PRT_BAKE (binary), LARGE_QUADS (terrain quads per side, default 708: 1,002,528
# triangles), LARGE_RELIEF (height scale, 4), LARGE_RES (2048), LARGE_SAMPLES (16), LARGE_BOUNCES (2), LARGE_ORDER (3),
# LARGE_OUT (folder, default target/bench-large; the scene and the bakes, ~1 GB).
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
[ "${1:-}" = --scale ] && exec "$root/scripts/bench/lightmap_scale.sh"
bake=$(realpath "${PRT_BAKE:-$root/target/release/prt-bake}")
shards=${1:-4}
quads=${LARGE_QUADS:-708}
out=${LARGE_OUT:-$root/target/bench-large}
[ -x "$bake" ] || { echo "bench-large: $bake is missing (cargo build --release)" >&2; exit 1; }
[ -x /usr/bin/time ] || { echo "bench-large: /usr/bin/time is missing (apt-get install time)" >&2; exit 1; }
mkdir -p "$out"
relief=${LARGE_RELIEF:-4}
scene=$out/terrain-$quads-$relief.gltf
[ -f "$scene" ] || python3 "$root/scripts/bench/large_scene.py" "$scene" "$quads" "$relief"
options=(--lightmap "${LARGE_RES:-2048}" --samples "${LARGE_SAMPLES:-16}" --mode interreflected
         --bounces "${LARGE_BOUNCES:-2}" --order "${LARGE_ORDER:-3}" --hit-cache-mb 8192 --quiet)
echo "bench-large: $scene, ${options[*]}, $shards shards, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"

# Runs a command under /usr/bin/time -v; prints its last output line, wall time and peak RSS.
timed() {
    local name=$1
    shift
    /usr/bin/time -v "$@" >"$out/$name.out" 2>"$out/$name.time"
    local wall rss
    wall=$(grep 'Elapsed (wall clock)' "$out/$name.time" | awk '{print $NF}')
    rss=$(grep 'Maximum resident' "$out/$name.time" | awk '{print $NF}')
    printf '%-8s wall %8s  peak %6d MB  %s\n' "$name" "$wall" $((rss / 1024)) "$(tail -n 1 "$out/$name.out")"
}

timed whole "$bake" bake "$scene" -o "$out/whole.prt" "${options[@]}"
parts=()
for ((k = 0; k < shards; k++)); do
    timed "shard-$k" "$bake" bake "$scene" -o "$out/part-$k.prt" --shard "$k/$shards" "${options[@]}"
    parts+=("$out/part-$k.prt")
done
timed merge "$bake" merge "${parts[@]}" -o "$out/merged.prt" --quiet
cmp "$out/whole.prt" "$out/merged.prt"
echo "bench-large: the merge of $shards shards equals the whole bake byte for byte ($(du -h "$out/whole.prt" | cut -f1), parts $(du -ch "${parts[@]}" | tail -n 1 | cut -f1))"

# The raw Embree rate of the same rays (benches/large.rs: bounce samples as closest-hit
# streams, the rest as occlusion streams) and the texel preparation alone; LARGE_RAW=0 skips it.
if [ "${LARGE_RAW:-1}" != 0 ]; then
    cargo bench -q -p prt-baker --bench large -- "$scene" "${LARGE_RES:-2048}" "${LARGE_SAMPLES:-16}" 2>&1 | grep '^raw Embree'
fi
echo "bench-large: CPU seconds (user + system) per run:"
for f in "$out"/*.time; do
    printf '  %-8s %s\n' "$(basename "$f" .time)" "$(awk -F': ' '/User time|System time/ {s += $2} END {print s}' "$f")"
done
