#!/usr/bin/env bash
# Bakes a scene on a Slurm cluster: an array job of N shards, then a merge job that runs when
# every shard has succeeded (--dependency=afterok). docs/distributed.md explains it.
#
#   scripts/slurm/submit.sh [--wait] SCENE OUT.prt N [bake options…]
#
#   --wait   block until the merge job has ended; exit with its status (non-zero when a shard
#            or the merge failed: the merge job is cancelled if a shard fails)
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
    echo "usage: $0 [--wait] SCENE OUT.prt N [bake options…]" >&2
    exit 2
}
wait_for_merge=""
if [ "${1:-}" = "--wait" ]; then
    wait_for_merge="--wait"
    shift
fi
[ $# -ge 3 ] || usage
scene=$1 out=$2 count=$3
shift 3
[[ "$count" =~ ^[1-9][0-9]*$ ]] || { echo "submit: N must be a positive whole number, not '$count'" >&2; exit 2; }
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

# The shards: array tasks 0..N-1; `--shard auto` reads SLURM_ARRAY_TASK_ID/COUNT.
array=$(sbatch --parsable "${extra[@]}" --job-name=prt-shard --array="0-$((count - 1))" \
    --output="$parts/shard-%a.log" \
    --wrap "$(quote "$bake" bake "$scene" -o "$parts/part-\$SLURM_ARRAY_TASK_ID.prt" --shard auto --quiet "$@" | sed 's/\\\$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_ID/')")
array=${array%%;*}

part_files=()
for ((k = 0; k < count; k++)); do part_files+=("$parts/part-$k.prt"); done
# The merge: only after every shard succeeded; cancelled (not left pending) if one failed.
merge_job=$(sbatch --parsable "${extra[@]}" --job-name=prt-merge \
    --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --output="$parts/merge.log" $wait_for_merge \
    --wrap "$(quote "$bake" merge "${part_files[@]}" -o "$out" --quiet)") || {
    status=$?
    echo "submit: the merge job failed (logs in $parts)" >&2
    exit $status
}
merge_job=${merge_job%%;*}
echo "submit: shards job $array (array 0-$((count - 1))), merge job $merge_job -> $out"
if [ -n "$wait_for_merge" ]; then
    # sbatch --wait exits 0 for a job cancelled before it started (a shard failed), so ask
    # the controller how the merge ended.
    state=$(scontrol show job "$merge_job" -o | grep -o 'JobState=[A-Z_]*' || true)
    if [ "$state" != "JobState=COMPLETED" ]; then
        echo "submit: the merge job ended with ${state:-an unknown state}: a shard failed? (logs in $parts)" >&2
        exit 1
    fi
fi
