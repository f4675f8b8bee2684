#!/usr/bin/env bash
# How texel bakes scale (`scripts/bench-large.sh --scale`, not part of
# `make test`): for each terrain size × lightmap resolution, the whole texel bake shadowed and
# interreflected, the vertex bake of the same mesh, the raw Embree rate of the same rays
# (baker/benches/large.rs), and for each shard count N the staged pipeline that
# `scripts/slurm/submit.sh --stages` submits (prepare-lightmap, factor-seams, N shards, merge
# --direct, per bounce N gathers and merge --lower, the last one stitching with the factor; or
# with SCALE_STITCH_SHARDS=M, the last merge --unstitched, M stitch column shards and stitch
# --join) run one after another here, its summed CPU against the whole bake's and its file compared byte for byte
# with the whole bake's. Every process runs under /usr/bin/time -v: wall, CPU (user + system)
# and peak RSS. Prints a table per cell, then the per-texel figures docs/guides/clusters.md's
# 16-node plan is built from, and leaves every figure in $SCALE_OUT/results.tsv.
#
#   scripts/bench/lightmap_scale.sh
#
# Environment (defaults: the full matrix, 1 M and 4 M triangles × 2048² and 4096²):
#   PRT_BAKE         the binary (default target/release/prt-bake)
#   SCALE_QUADS      terrain quads per side, a list (708 1415: 1,002,528 and 4,004,450 triangles)
#   SCALE_RES        lightmap resolutions, a list (2048 4096)
#   SCALE_CELLS      QUADS:RES pairs instead of the full matrix ("708:2048 708:4096")
#   SCALE_SHARDS     shard counts of the staged pipeline, a list (2 4; empty: none)
#   SCALE_SAMPLES    rays per texel of the shadowed bakes and the vertex bake (64)
#   SCALE_IR_SAMPLES rays per texel of the interreflected bakes (16, bench-large's)
#   SCALE_BOUNCES    bounces of the interreflected bakes (2)
#   SCALE_STAGE_MODES modes run staged (interreflected; "shadowed interreflected" for both)
#   SCALE_STITCH_SHARDS stitch column shards after the last merge, as `submit.sh --stitch-shards
#                    M` (default 0: the last merge stitches with the seam factor, submit.sh's
#                    default)
#   SCALE_ORDER      SH order (3)
#   SCALE_ATLAS      empty: the scene's own lightmap UVs (TEXCOORD_1, one chart); planar or
#                    unwrap: an atlas made by the bake (the raw Embree rate is then skipped:
#                    benches/large.rs reads TEXCOORD_1)
#   SCALE_RELIEF     terrain height scale (4)
#   SCALE_RAW        0 skips the raw Embree rate (it costs about one whole bake per mode)
#   SCALE_KEEP       1 keeps every cell's bakes (default: deleted once compared; a 4096² cell
#                    writes several GB)
#   SCALE_OUT        folder (default target/bench-scale): scenes, logs, results.tsv
#   SCALE_DENOISE    --denoise of every bake, whole and staged (default off; auto denoises the
#                    texel bakes: the staged pipeline's last merge then denoises as the whole
#                    bake does)
#   SCALE_WHOLE      the whole bakes run, a list (default "vertex shadowed interreflected"; the
#                    staged pipelines need the whole bakes of their modes)
# The staged pipeline's fixed costs at low ray counts (docs/explanation/performance.md): SCALE_CELLS=600:1024
# SCALE_SHARDS=2 SCALE_RAW=0 SCALE_WHOLE=interreflected SCALE_DENOISE=auto (720,000 triangles).
# A quick run: SCALE_CELLS=354:1024 SCALE_SHARDS=2 (250,632 triangles, 1024²), about 2 CPU-minutes
# (the 512² cell of the same terrain measured 27 CPU-s without the raw rate; 100:256 takes seconds).
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
bake=$(realpath "${PRT_BAKE:-$root/target/release/prt-bake}")
out=$(realpath -m "${SCALE_OUT:-$root/target/bench-scale}")
samples=${SCALE_SAMPLES:-64}
ir_samples=${SCALE_IR_SAMPLES:-16}
bounces=${SCALE_BOUNCES:-2}
order=${SCALE_ORDER:-3}
atlas=${SCALE_ATLAS:-}
relief=${SCALE_RELIEF:-4}
shards=${SCALE_SHARDS-2 4}
stage_modes=${SCALE_STAGE_MODES:-interreflected}
stitch_shards=${SCALE_STITCH_SHARDS:-0}
denoise=${SCALE_DENOISE:-off}
whole_runs=" ${SCALE_WHOLE:-vertex shadowed interreflected} "
[[ "$stitch_shards" =~ ^[0-9]+$ ]] || { echo "lightmap_scale: SCALE_STITCH_SHARDS takes a whole number, not '$stitch_shards'" >&2; exit 2; }
[ -x "$bake" ] || { echo "lightmap_scale: $bake is missing (cargo build --release)" >&2; exit 1; }
[ -x /usr/bin/time ] || { echo "lightmap_scale: /usr/bin/time is missing (apt-get install time)" >&2; exit 1; }
if [ -n "${SCALE_CELLS:-}" ]; then
    read -r -a cells <<<"$SCALE_CELLS"
else
    cells=()
    for q in ${SCALE_QUADS:-708 1415}; do
        for r in ${SCALE_RES:-2048 4096}; do cells+=("$q:$r"); done
    done
fi
mkdir -p "$out"
results=$out/results.tsv
printf 'cell\trun\twall_s\tcpu_s\trss_mb\trays\ttexels\tseam_points\tbytes\tsystem_s\tfaults\n' >"$results"
threads=$(nproc)
differs=""
echo "lightmap_scale: $bake, cells ${cells[*]}, shards ${shards:-none}, order $order, shadowed $samples rays," \
    "interreflected $ir_samples rays $bounces bounces, atlas ${atlas:-TEXCOORD_1}, $threads cores," \
    "load $(cut -d' ' -f1-3 /proc/loadavg), $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?')"

# Seconds from /usr/bin/time's h:mm:ss or m:ss.
seconds() { awk -F: '{ s = 0; for (i = 1; i <= NF; i++) s = s * 60 + $i; print s }' <<<"$1"; }

# timed CELL DIR NAME COMMAND…: runs COMMAND under /usr/bin/time -v (stdout DIR/NAME.out,
# stderr DIR/NAME.err), stops the benchmark if it fails, appends a row to results.tsv.
timed() {
    local cell=$1 dir=$2 name=$3
    shift 3
    if ! /usr/bin/time -v -o "$dir/$name.time" "$@" >"$dir/$name.out" 2>"$dir/$name.err"; then
        echo "lightmap_scale: $name failed:" >&2
        tail -n 5 "$dir/$name.err" >&2
        exit 1
    fi
    local wall cpu system faults rss rays texels seams
    wall=$(seconds "$(grep 'Elapsed (wall clock)' "$dir/$name.time" | awk '{print $NF}')")
    cpu=$(awk -F': ' '/User time|System time/ {s += $2} END {printf "%.2f", s}' "$dir/$name.time")
    system=$(awk -F': ' '/System time/ {printf "%.2f", $2}' "$dir/$name.time")
    faults=$(awk -F': ' '/Minor \(reclaiming a frame\) page faults/ {print $2}' "$dir/$name.time")
    rss=$(awk '/Maximum resident/ {printf "%d", $NF / 1024}' "$dir/$name.time")
    # The bake's summary line: "baked R of WxH texels, S seam points, N rays, …" or
    # "baked V vertices, N rays, …".
    rays=$(grep -ho '[0-9]* rays' "$dir/$name.out" "$dir/$name.err" | head -n 1 | cut -d' ' -f1 || true)
    texels=$(grep -hoE 'baked [0-9]+ (of|vertices)' "$dir/$name.out" "$dir/$name.err" | head -n 1 | cut -d' ' -f2 || true)
    seams=$(grep -hoE '[0-9]+ seam points' "$dir/$name.out" "$dir/$name.err" | head -n 1 | cut -d' ' -f1 || true)
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t\t%s\t%s\n' "$cell" "$name" "$wall" "$cpu" "$rss" "${rays:-}" \
        "${texels:-}" "${seams:-}" "$system" "$faults" >>"$results"
    printf '  %-22s wall %8.2f s  CPU %8.2f s (system %6.2f)  peak %6d MB\n' "$name" "$wall" "$cpu" "$system" "$rss"
    # A --verbose bake's stages: their summed CPU as a row "NAME:stages" (the rest of the
    # process is loading the scene and building its BVH), and printed, CPU seconds only.
    local staged_cpu
    staged_cpu=$(grep -h 'stages:' "$dir/$name.err" | grep -oE 'CPU [0-9.]+ s' | awk '{s += $2} END {if (NR) printf "%.2f", s}' || true)
    [ -n "$staged_cpu" ] && printf '%s\t%s\t\t%s\t\t\t\t\t\n' "$cell" "$name:stages" "$staged_cpu" >>"$results"
    if [ -n "$staged_cpu" ]; then
        grep -h 'stages:' "$dir/$name.err" | sed -E 's/^prt-bake: stages: //; s/ [0-9.]+ s \(CPU ([0-9.]+) s\)/ \1/g' |
            paste -sd';' | sed 's/;/; /g; s/^/    CPU-s by stage: /'
    fi
}
# size CELL NAME FILE…: records the files' total bytes as a row.
size() {
    local cell=$1 name=$2
    shift 2
    printf '%s\t%s\t\t\t\t\t\t\t%s\n' "$cell" "$name" "$(stat -c %s "$@" | awk '{s += $1} END {print s}')" >>"$results"
}

# The staged pipeline of N shards for MODE (options in the rest), compared with WHOLE.
staged() {
    local cell=$1 dir=$2 scene=$3 mode=$4 n=$5 whole=$6
    shift 6
    local s="$dir/stages-$mode-$n" tag="$mode-N$n"
    mkdir -p "$s"
    echo " staged $mode, $n shards:"
    timed "$cell" "$s" "$tag:prepare" "$bake" prepare-lightmap "$scene" -o "$s/prep.lmp" --quiet --verbose "$@"
    # The seam stitch's system, factored once for the last merge or the stitch shards (on Slurm
    # beside the shards).
    timed "$cell" "$s" "$tag:factor" "$bake" factor-seams "$s/prep.lmp" -o "$s/seams.fac"
    size "$cell" "$tag:file-factor" "$s/seams.fac"
    local parts=() k b
    for ((k = 0; k < n; k++)); do
        timed "$cell" "$s" "$tag:shard-$k" "$bake" bake "$scene" --prepared "$s/prep.lmp" --shard "$k/$n" \
            -o "$s/part-$k.prt" --quiet --verbose "$@"
        parts+=("$s/part-$k.prt")
    done
    size "$cell" "$tag:file-prepared" "$s/prep.lmp"
    size "$cell" "$tag:file-parts" "${parts[@]}"
    # How the last merge ends: stitching with the factor into the staged file, or unstitched
    # for the column shards.
    local final=(--factor "$s/seams.fac" -o "$s/staged.prt")
    [ "$stitch_shards" -gt 0 ] && final=(--unstitched -o "$s/unstitched.prt")
    if [ "$mode" = interreflected ]; then
        timed "$cell" "$s" "$tag:merge-direct" "$bake" merge --direct "${parts[@]}" -o "$s/bounce-0.bnc" --quiet
        size "$cell" "$tag:file-bounce" "$s/bounce-0.bnc"
        for ((b = 1; b <= bounces; b++)); do
            local gathers=() last=(-o "$s/bounce-$b.bnc")
            for ((k = 0; k < n; k++)); do
                timed "$cell" "$s" "$tag:gather-$b-$k" "$bake" gather "${parts[k]}" --lower "$s/bounce-$((b - 1)).bnc" \
                    -o "$s/gather-$b-$k.bnc" --quiet
                gathers+=("$s/gather-$b-$k.bnc")
            done
            [ "$b" -eq 1 ] && size "$cell" "$tag:file-gathers" "${gathers[@]}"
            [ "$b" -eq "$bounces" ] && last=("${final[@]}")
            timed "$cell" "$s" "$tag:merge-lower-$b" "$bake" merge --lower "$s/bounce-$((b - 1)).bnc" "${last[@]}" \
                "${gathers[@]}" --quiet
            # What no later stage reads (a 4096² pipeline's files outgrow a small disk).
            [ "${SCALE_KEEP:-0}" = 1 ] || rm -f "$s/bounce-$((b - 1)).bnc" "${gathers[@]}"
        done
        [ "${SCALE_KEEP:-0}" = 1 ] || rm -f "${parts[@]}"
    elif [ "$stitch_shards" -gt 0 ]; then
        timed "$cell" "$s" "$tag:merge-unstitched" "$bake" merge "${parts[@]}" "${final[@]}" --quiet
    else
        timed "$cell" "$s" "$tag:merge" "$bake" merge "${parts[@]}" "${final[@]}" --quiet
    fi
    if [ "$stitch_shards" -gt 0 ]; then
        local columns=()
        for ((k = 0; k < stitch_shards; k++)); do
            timed "$cell" "$s" "$tag:stitch-$k" "$bake" stitch "$s/unstitched.prt" --factor "$s/seams.fac" \
                --columns "$k/$stitch_shards" -o "$s/columns-$k.col"
            columns+=("$s/columns-$k.col")
        done
        size "$cell" "$tag:file-columns" "${columns[@]}"
        timed "$cell" "$s" "$tag:join" "$bake" stitch "$s/unstitched.prt" --join "${columns[@]}" -o "$s/staged.prt"
    fi
    if cmp -s "$whole" "$s/staged.prt"; then
        echo "  the staged file equals the whole bake's byte for byte"
        printf '%s\t%s\t\t\t\t\t\t\t1\n' "$cell" "$tag:identical" >>"$results"
    else
        echo "lightmap_scale: $s/staged.prt differs from $whole" >&2
        differs=1
        printf '%s\t%s\t\t\t\t\t\t\t0\n' "$cell" "$tag:identical" >>"$results"
    fi
    [ "${SCALE_KEEP:-0}" = 1 ] || [ -n "$differs" ] || rm -rf "$s"
}

for cell in "${cells[@]}"; do
    quads=${cell%%:*} res=${cell##*:}
    scene=$out/terrain-$quads-$relief.gltf
    [ -f "$scene" ] || python3 "$root/scripts/bench/large_scene.py" "$scene" "$quads" "$relief" >/dev/null
    dir=$out/cell-$quads-$res
    rm -rf "$dir"
    mkdir -p "$dir"
    echo "cell $cell: $((2 * quads * quads)) triangles, ${res}², load $(cut -d' ' -f1-3 /proc/loadavg)"
    # The whole bakes take the staged ones' --denoise, as they are compared byte for byte.
    lm=(--lightmap "$res" --order "$order" --denoise "$denoise")
    [ -n "$atlas" ] && lm+=(--atlas "$atlas")
    shadowed=("${lm[@]}" --samples "$samples")
    # Parts carry their bounce rows, which at 4096² outgrow the 1 GiB default limit.
    inter=("${lm[@]}" --samples "$ir_samples" --mode interreflected --bounces "$bounces" --hit-cache-mb 16384)
    if [[ "$whole_runs" == *" vertex "* ]]; then
        timed "$cell" "$dir" vertex "$bake" bake "$scene" -o "$dir/vertex.prt" --order "$order" --samples "$samples" --quiet --verbose
        rm -f "$dir/vertex.prt"
    fi
    if [[ "$whole_runs" == *" shadowed "* ]]; then
        timed "$cell" "$dir" shadowed "$bake" bake "$scene" -o "$dir/shadowed.prt" "${shadowed[@]}" --quiet --verbose
        size "$cell" shadowed:file "$dir/shadowed.prt"
    fi
    if [[ "$whole_runs" == *" interreflected "* ]]; then
        timed "$cell" "$dir" interreflected "$bake" bake "$scene" -o "$dir/interreflected.prt" "${inter[@]}" --quiet --verbose
        size "$cell" interreflected:file "$dir/interreflected.prt"
    fi
    if [ "${SCALE_RAW:-1}" != 0 ] && [ -z "$atlas" ]; then
        for mode in shadowed interreflected; do
            if [ "$mode" = shadowed ]; then raw=("$samples" 0); else raw=("$ir_samples"); fi
            line=$(cd "$root" && cargo bench -q -p prt-baker --bench large -- "$scene" "$res" "${raw[@]}" 2>&1 | grep '^raw Embree' || true)
            # "raw Embree: T texels × S rays (B closest-hit), N threads: X s CPU per thread, R Mrays/s; …"
            cpu=$(sed -nE 's/.*threads: ([0-9.]+) s CPU per thread.*/\1/p' <<<"$line")
            rays=$(sed -nE 's/raw Embree: ([0-9]+) texels × ([0-9]+) rays.*/\1 \2/p' <<<"$line" | awk '{print $1 * $2}')
            threads_used=$(sed -nE 's/.* ([0-9]+) threads:.*/\1/p' <<<"$line")
            [ -n "$cpu" ] || { echo "  raw Embree ($mode): no figure ($line)"; continue; }
            printf '%s\t%s\t\t%s\t\t%s\t\t\t\n' "$cell" "raw-$mode" "$(awk -v c="$cpu" -v t="$threads_used" 'BEGIN {printf "%.2f", c * t}')" \
                "$rays" >>"$results"
            echo "  $line"
        done
    fi
    for n in $shards; do
        for mode in $stage_modes; do
            if [ "$mode" = shadowed ]; then
                staged "$cell" "$dir" "$scene" shadowed "$n" "$dir/shadowed.prt" "${shadowed[@]}"
            else
                staged "$cell" "$dir" "$scene" interreflected "$n" "$dir/interreflected.prt" "${inter[@]}"
            fi
        done
    done
    [ "${SCALE_KEEP:-0}" = 1 ] || rm -f "$dir"/*.prt
    python3 "$root/scripts/bench/scale_report.py" "$results" --cell "$cell" --threads "$threads"
done
echo
python3 "$root/scripts/bench/scale_report.py" "$results" --threads "$threads"
if [ -n "$differs" ]; then
    echo "lightmap_scale: a staged bake differs from the whole bake (above)" >&2
    exit 1
fi
