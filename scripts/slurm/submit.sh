#!/usr/bin/env bash
# Bakes a scene on a Slurm cluster: an array job of N shards, then a merge job that runs when
# every shard has succeeded (--dependency=afterok). docs/guides/clusters.md explains it.
#
#   scripts/slurm/submit.sh [--wait] [--stages [--stitch-shards M]] SCENE OUT.prt N [bake options…]
#
#   --wait    block until the last job has ended; exit non-zero unless it completed (a shard
#             or a merge failed: the jobs after a failed one are cancelled)
#   --stages  a texel bake (--lightmap) in dependent stages, so that no job repeats another's
#             work and the merges do no heavy work: a prepare-lightmap job; the shards' array
#             (reading the prepared lightmap) and beside it a `factor-seams` job (the seam
#             stitch's system factored once); in interreflected mode `merge --direct`, then
#             per bounce an array of N `gather` tasks and a `merge --lower`; the last merge
#             (after the factor job too) solves the seams with the factor and writes OUT.prt
#   --stitch-shards M
#             with --stages, M >= 1: the last merge writes the file unstitched, then an array
#             of M `stitch --columns --factor` tasks and a `stitch --join` (for lightmaps
#             whose seam solve is large); 0: the last merge factors and stitches itself, with
#             no factor job (docs/guides/clusters.md)
#
# Environment:
#   PRT_BAKE        the prt-bake binary the nodes run (default: target/release/prt-bake of this
#                   checkout); it, the scene and OUT's folder must be on a file system that the
#                   nodes share
#   PRT_PARTS       folder for the parts and the jobs' logs (default: OUT.prt.parts)
#   SBATCH_OPTIONS  extra sbatch options for both jobs (partition, account, time, …)
#
# Prints the two job ids. The parts stay in PRT_PARTS after the merge (delete them once the
# merged file is checked).
set -euo pipefail

usage() {
    echo "usage: $0 [--wait] [--stages [--stitch-shards M]] SCENE OUT.prt N [bake options…]" >&2
    exit 2
}
wait_for_merge="" stages="" stitch_shards=""
while [ $# -gt 0 ]; do
    case $1 in
        --wait) wait_for_merge="--wait" ;;
        --stages) stages=1 ;;
        --stitch-shards)
            stitch_shards=${2:-}
            [[ "$stitch_shards" =~ ^[0-9]+$ ]] || { echo "submit: --stitch-shards takes a whole number, not '$stitch_shards'" >&2; exit 2; }
            stitch_shards=$((10#$stitch_shards))
            shift ;;
        *) break ;;
    esac
    shift
done
[ $# -ge 3 ] || usage
scene=$1 out=$2 count=$3
shift 3
[[ "$count" =~ ^[1-9][0-9]*$ ]] || { echo "submit: N must be a positive whole number, not '$count'" >&2; exit 2; }
[ -z "$stitch_shards" ] || [ -n "$stages" ] || { echo "submit: --stitch-shards is for --stages" >&2; exit 2; }
[ -f "$scene" ] || { echo "submit: $scene: no such scene file" >&2; exit 3; }

root=$(cd "$(dirname "$0")/../.." && pwd)
bake=$(realpath "${PRT_BAKE:-$root/target/release/prt-bake}")
[ -x "$bake" ] || { echo "submit: $bake is not an executable (build it, or set PRT_BAKE)" >&2; exit 1; }
scene=$(realpath "$scene")
out=$(realpath -m "$out")
parts=$(realpath -m "${PRT_PARTS:-$out.parts}")
mkdir -p "$parts"

quote() { printf '%q ' "$@"; }
# shellcheck disable=SC2206
extra=(${SBATCH_OPTIONS:-})

if [ -n "$stages" ]; then
    # The stages' options: --lightmap is required; interreflected bakes have --bounces (1 by
    # default) bounces to gather.
    mode=shadowed bounces="" lightmap=""
    args=("$@")
    for ((i = 0; i < ${#args[@]}; i++)); do
        case ${args[i]} in
            --mode) mode=${args[i + 1]:-} ;;
            --mode=*) mode=${args[i]#--mode=} ;;
            --bounces) bounces=${args[i + 1]:-} ;;
            --bounces=*) bounces=${args[i]#--bounces=} ;;
            --lightmap | --lightmap=*) lightmap=1 ;;
        esac
    done
    [ -n "$lightmap" ] || { echo "submit: --stages is for texel bakes: give --lightmap RES" >&2; exit 2; }
    [ "$mode" = interreflected ] || bounces=0
    bounces=${bounces:-1}
fi

# Submits one job (or with "array", an array of N tasks; "array:M", of M) that runs when job
# $after (if any) has succeeded, and is cancelled if it failed; prints its id. $1 is the
# job's name.
submit() {
    local name=$1 after=$2 array=$3 wrap=$4
    local opts=(--parsable "${extra[@]}" --job-name="prt-$name")
    [ -n "$after" ] && opts+=(--dependency="afterok:$after" --kill-on-invalid-dep=yes)
    if [ -n "$array" ]; then
        local tasks=$count
        [ "$array" = array ] || tasks=${array#array:}
        opts+=(--array="0-$((tasks - 1))" --output="$parts/$name-%a.log")
    else
        opts+=(--output="$parts/$name.log")
    fi
    local id
    id=$(sbatch "${opts[@]}" --wrap "$wrap") || {
        local status=$?
        echo "submit: the $name job failed (logs in $parts)" >&2
        exit $status
    }
    echo "${id%%;*}"
}
# Files of every array task: "$1-0$2 $1-1$2 …" ($3 tasks, default N).
each() { for ((k = 0; k < ${3:-$count}; k++)); do printf '%q ' "$1-$k$2"; done; }
task='$SLURM_ARRAY_TASK_ID'

part_files=()
for ((k = 0; k < count; k++)); do part_files+=("$parts/part-$k.prt"); done
if [ -n "$stages" ]; then
    prep="$parts/prepared.lmp"
    prepare_job=$(submit prepare "" "" "$(quote "$bake" prepare-lightmap "$scene" -o "$prep" --quiet "$@")")
    # The seams' system, factored once (for the last merge or every stitch shard), beside the
    # shards (no rays); `--stitch-shards 0`: the last merge factors it.
    factor_job="" factor="$parts/seams.fac"
    if [ "$stitch_shards" != 0 ]; then
        factor_job=$(submit factor "$prepare_job" "" "$(quote "$bake" factor-seams "$prep" -o "$factor")")
    fi
    # The shards read the prepared lightmap: none repeats the atlas or the leak test.
    array=$(submit shard "$prepare_job" array "$(quote "$bake" bake "$scene" --shard auto --prepared "$prep" --quiet "$@") -o $(printf '%q' "$parts/part-")$task.prt")
    # How the last merge ends: stitching with the factor (after the factor job too), leaving
    # the seams to column shards, or factoring and stitching itself.
    unstitched="$parts/unstitched.prt" final=$out after_factor=""
    case $stitch_shards in
        "") stitching=(--factor "$factor") after_factor=":$factor_job" ;;
        0) stitching=() ;;
        *) stitching=(--unstitched) final=$unstitched ;;
    esac
    last=$array
    if [ "$bounces" -eq 0 ]; then
        last=$(submit merge "$last$after_factor" "" "$(quote "$bake" merge "${part_files[@]}" "${stitching[@]}" -o "$final" --quiet)")
    else
        last=$(submit merge-0 "$last" "" "$(quote "$bake" merge --direct "${part_files[@]}" -o "$parts/bounce-0.bnc" --quiet)")
        for ((b = 1; b <= bounces; b++)); do
            lower="$parts/bounce-$((b - 1)).bnc"
            last=$(submit "gather-$b" "$last" array "$(quote "$bake" gather --quiet --lower "$lower") $(printf '%q' "$parts/part-")$task.prt -o $(printf '%q' "$parts/gather-$b-")$task.bnc")
            if [ "$b" -lt "$bounces" ]; then
                last=$(submit "merge-$b" "$last" "" "$(quote "$bake" merge --lower "$lower" -o "$parts/bounce-$b.bnc" --quiet) $(each "$parts/gather-$b" .bnc)")
            else
                last=$(submit "merge-$b" "$last$after_factor" "" "$(quote "$bake" merge --lower "$lower" "${stitching[@]}" -o "$final" --quiet) $(each "$parts/gather-$b" .bnc)")
            fi
        done
    fi
    case $stitch_shards in
        "")
            merge_job=$last
            echo "submit: prepare job $prepare_job, shards job $array (array 0-$((count - 1))), seam factor job $factor_job, $((bounces)) bounce stages, the last merge (stitching with the factor) job $merge_job -> $out" ;;
        0)
            merge_job=$last
            echo "submit: prepare job $prepare_job, shards job $array (array 0-$((count - 1))), $((bounces)) bounce stages, the last merge (factoring and stitching) job $merge_job -> $out" ;;
        *)
            # Stitching in M shards of columns, each solving with the factor; the join is I/O.
            last=$(submit stitch "$last:$factor_job" "array:$stitch_shards" "$(quote "$bake" stitch "$unstitched" --factor "$factor" --columns auto) -o $(printf '%q' "$parts/columns-")$task.col")
            merge_job=$(submit join "$last" "" "$(quote "$bake" stitch "$unstitched" -o "$out" --join) $(each "$parts/columns" .col "$stitch_shards")")
            echo "submit: prepare job $prepare_job, shards job $array (array 0-$((count - 1))), $((bounces)) bounce stages, seam factor job $factor_job, stitch ($stitch_shards shards) and join job $merge_job -> $out" ;;
    esac
else
    # The shards: array tasks 0..N-1; `--shard auto` reads SLURM_ARRAY_TASK_ID/COUNT.
    array=$(submit shard "" array "$(quote "$bake" bake "$scene" --shard auto --quiet "$@") -o $(printf '%q' "$parts/part-")$task.prt")
    # The merge: only after every shard succeeded; cancelled (not left pending) if one failed.
    merge_job=$(submit merge "$array" "" "$(quote "$bake" merge "${part_files[@]}" -o "$out" --quiet)")
    echo "submit: shards job $array (array 0-$((count - 1))), merge job $merge_job -> $out"
fi
if [ -n "$wait_for_merge" ]; then
    # Polls the last job twice a second (sbatch --wait backs off to 30 s and more between
    # polls, which a bake in many short stages would spend waiting).
    state=""
    while :; do
        state=$(scontrol show job "$merge_job" -o 2>/dev/null | grep -o 'JobState=[A-Z_]*' || true)
        case $state in
            JobState=PENDING | JobState=RUNNING | JobState=CONFIGURING | JobState=COMPLETING | JobState=SUSPENDED | JobState=REQUEUED) sleep 0.5 ;;
            *) break ;;
        esac
    done
    if [ "$state" != "JobState=COMPLETED" ]; then
        echo "submit: the last job ended with ${state:-an unknown state}: a shard failed? (logs in $parts)" >&2
        exit 1
    fi
fi
