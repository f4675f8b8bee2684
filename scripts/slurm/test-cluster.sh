#!/usr/bin/env bash
# A real single-node Slurm cluster (Debian 12's slurm-wlm 22.05 and munge), started for one
# test and stopped again: scripts/slurm/submit.sh bakes the Cornell room in 4 shards and merges
# them, then its 64² lightmap in 2 shards in stages (interreflected, the last merge stitching
# with the seam factor; shadowed, stitched in column shards), and each merged file must equal
# the single-machine bake byte for byte.
#
#   scripts/slurm/test-cluster.sh [PRT_BAKE]
#
# Everything lives in a temporary folder: slurm.conf, the munge key and socket, the state and
# spool folders, the logs. The daemons (munged, slurmctld, slurmd) listen on localhost ports
# and are stopped by their pids when the test ends, passes or fails. No systemd. The daemons
# run as root, so the test needs root; it is skipped (with a message) otherwise.
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
bake=$(realpath "${1:-$root/target/release/prt-bake}")
scene=$root/scenes/cornell/cornell.scene
bake_options=(--samples 256 --mode interreflected --bounces 2 --aux ao)
# The texel bake: small and few rays, so it adds seconds, not minutes. One bounce: Slurm starts
# a dependent job about a second after the one before at best, so every stage costs seconds
# (the chain of bounces is tested in baker/tests/cli_lightmap_stages.rs).
texel_options=(--lightmap 64 --samples 64 --mode interreflected --bounces 1 --aux ao,bent-normal)

if [ "$(id -u)" -ne 0 ]; then
    echo "slurm test: SKIPPED: the test's Slurm and munge daemons must run as root (run make test as root)"
    exit 0
fi
for tool in munged slurmctld slurmd sbatch sinfo; do
    command -v "$tool" >/dev/null || { echo "slurm test: $tool is missing (scripts/install-deps.sh installs it)" >&2; exit 1; }
done
[ -x "$bake" ] || { echo "slurm test: $bake is missing (cargo build --release)" >&2; exit 1; }

tmp=$(mktemp -d /tmp/prt-slurm.XXXXXX)
pids=()
teardown() {
    status=$?
    # slurmd, slurmctld, then munged (which the other two talk to).
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do kill "${pids[i]}" 2>/dev/null || true; done
    for pid in "${pids[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null || true
    done
    if [ $status -ne 0 ]; then
        echo "slurm test: FAILED; the logs of the daemons and the jobs:" >&2
        tail -n 20 "$tmp"/*.log "$tmp"/*.prt.parts/*.log >&2 2>/dev/null || true
    fi
    rm -rf "$tmp"
    exit $status
}
trap teardown EXIT
trap 'exit 1' INT TERM

# Free localhost ports for slurmctld and slurmd.
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')

mkdir -p "$tmp/state" "$tmp/spool" "$tmp/munge"
chmod 700 "$tmp/munge"
head -c 1024 /dev/urandom > "$tmp/munge/munge.key"
chmod 400 "$tmp/munge/munge.key"
socket=$tmp/munge/munge.socket
cpus=$(nproc)
cat > "$tmp/slurm.conf" <<CONF
ClusterName=prt-test
SlurmctldHost=localhost
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
# Run the scheduler as soon as a job ends (default: at most every 2 s), so that the texel
# bake's dependent stages follow each other without waiting.
SchedulerParameters=sched_min_interval=100000
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
SwitchType=switch/none
PlugStackConfig=$tmp/plugstack.conf
SlurmdParameters=config_overrides
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
: > "$tmp/plugstack.conf"
export SLURM_CONF=$tmp/slurm.conf

# Waits up to $1 seconds for the command that follows to succeed.
wait_for() {
    local seconds=$1
    shift
    for _ in $(seq $((seconds * 10))); do
        "$@" >/dev/null 2>&1 && return 0
        sleep 0.1
    done
    echo "slurm test: timed out after ${seconds}s waiting for: $*" >&2
    return 1
}

munged --foreground --force --socket="$socket" --key-file="$tmp/munge/munge.key" \
    --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munged.log" \
    --seed-file="$tmp/munge/munge.seed" 2>>"$tmp/munged.log" &
pids+=($!)
wait_for 10 test -S "$socket"
# In the foreground (-D) so that $! is the daemon; their stderr joins their logs.
slurmctld -D -i -f "$SLURM_CONF" 2>>"$tmp/slurmctld.log" &
pids+=($!)
slurmd -D -f "$SLURM_CONF" 2>>"$tmp/slurmd.log" &
pids+=($!)
wait_for 30 bash -c 'sinfo -h -o %T | grep -qx idle'
echo "slurm test: cluster up (slurmctld :$ctld_port, slurmd :$slurmd_port, $cpus CPUs)"

SECONDS=0
timeout 120 "$root/scripts/slurm/submit.sh" --wait "$scene" "$tmp/merged.prt" 4 "${bake_options[@]}"
slurm_seconds=$SECONDS
for k in 0 1 2 3; do
    grep -q "shard $k of 4" "$tmp/merged.prt.parts/shard-$k.log" ||
        { echo "slurm test: shard $k's log does not say it baked shard $k of 4" >&2; exit 1; }
done
timeout 120 "$bake" bake "$scene" -o "$tmp/single.prt" --quiet "${bake_options[@]}" >/dev/null
cmp "$tmp/merged.prt" "$tmp/single.prt"
echo "slurm test: 4 shards on Slurm, merged by a dependent job in ${slurm_seconds}s: identical to the single-machine bake"

# Two texel (lightmap) bakes in dependent stages (--stages), submitted side by side (a stage
# waits for the scheduler more than it computes). The interreflected one: a prepare job, the
# shards and beside them the seam factor, merge --direct, the bounce's gathers and the last
# merge, which stitches with the factor (5 stages). The shadowed one stitches in column shards
# (--stitch-shards 2): prepare, the shards and the factor, the merge writing it unstitched, 2
# stitch shards solving with the factor, the join (5 stages). The last merge stitching itself
# (`--stitch-shards 0`) is tested in baker/tests/cli_lightmap_stages.rs.
shadowed_options=(--lightmap 64 --samples 16 --mode shadowed --aux ao)
SECONDS=0
timeout 180 "$root/scripts/slurm/submit.sh" --wait --stages "$scene" "$tmp/texels.prt" 2 "${texel_options[@]}" &
texels_pid=$!
timeout 180 "$root/scripts/slurm/submit.sh" --wait --stages --stitch-shards 2 "$scene" "$tmp/columns.prt" 2 "${shadowed_options[@]}" &
columns_pid=$!
wait "$texels_pid"
wait "$columns_pid"
slurm_seconds=$SECONDS
grep -q "factored .* seam unknowns" "$tmp/texels.prt.parts/factor.log" ||
    { echo "slurm test: the factor job's log does not say it factored the seams" >&2; exit 1; }
grep -q "stitched with .*seams.fac" "$tmp/texels.prt.parts/merge-1.log" ||
    { echo "slurm test: the last merge's log does not say it stitched with the factor" >&2; exit 1; }
for k in 0 1; do
    grep -q "shard $k of 2 (baked texels" "$tmp/texels.prt.parts/shard-$k.log" ||
        { echo "slurm test: texel shard $k's log does not say it baked shard $k of 2's texels" >&2; exit 1; }
    grep -q "gathered bounce 1 of 1 (shard $k of 2" "$tmp/texels.prt.parts/gather-1-$k.log" ||
        { echo "slurm test: gather task $k's log does not say it gathered shard $k's bounce 1" >&2; exit 1; }
    [ -s "$tmp/columns.prt.parts/columns-$k.col" ] ||
        { echo "slurm test: stitch shard $k wrote no column file" >&2; exit 1; }
done
timeout 120 "$bake" bake "$scene" -o "$tmp/texels-single.prt" --quiet "${texel_options[@]}" >/dev/null
cmp "$tmp/texels.prt" "$tmp/texels-single.prt"
timeout 120 "$bake" bake "$scene" -o "$tmp/columns-single.prt" --quiet "${shadowed_options[@]}" >/dev/null
cmp "$tmp/columns.prt" "$tmp/columns-single.prt"
echo "slurm test: 64² lightmaps in 2 shards on Slurm, in dependent stages, in ${slurm_seconds}s: interreflected (the last merge stitching with the seam factor) and shadowed (2 stitch shards and a join), each denoised (--denoise auto) and identical to the single-machine texel bake"
