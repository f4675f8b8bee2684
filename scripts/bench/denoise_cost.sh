#!/usr/bin/env bash
# What denoising costs (not part of `make test`): bakes BAKE-ARGUMENTS on one thread, raw
# (`--denoise off`) and denoised (`--denoise on`) in turn, REPS times each, and prints each
# run's CPU (user + system). Texel bakes print their denoise stage's own CPU (`--verbose`);
# vertex bakes have no such line, so their filter's cost is the denoised bake's CPU less the
# raw one's. Alternating runs keep the two sides under the same load on a shared machine.
#
#   scripts/bench/denoise_cost.sh BAKE-ARGUMENTS...
#   REPS=5 scripts/bench/denoise_cost.sh scenes/cornell/cornell.scene --lightmap 256 --order 3 --samples 64
#
# Prints one line a run, then the medians and the filter's cost over the raw bake's CPU.
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
bake=${PRT_BAKE:-$root/target/release/prt-bake}
reps=${REPS:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

for _ in $(seq "$reps"); do
    for denoise in off on; do
        /usr/bin/time -f "TIME %U %S" -o "$work/time" "$bake" bake "$@" --threads 1 --verbose \
            --denoise "$denoise" -o "$work/out.prt" >"$work/log" 2>&1
        cpu=$(awk '/^TIME/ { printf "%.2f", $2 + $3 }' "$work/time")
        stage=$(grep -o "denoise [0-9.]* s (CPU [0-9.]* s)" "$work/log" | awk '{ print $5 }' || true)
        echo "$denoise $cpu ${stage:--}"
    done
done | tee "$work/runs" | awk '{ printf "%-4s CPU %s s, stage %s\n", $1, $2, $3 }'

python3 - "$work/runs" <<'EOF'
import statistics, sys
runs = [line.split() for line in open(sys.argv[1])]
raw = statistics.median(float(r[1]) for r in runs if r[0] == "off")
on = statistics.median(float(r[1]) for r in runs if r[0] == "on")
stages = [float(r[2]) for r in runs if r[0] == "on" and r[2] != "-"]
cost = statistics.median(stages) if stages else on - raw
what = "the stage" if stages else "denoised less raw"
print(f"median: raw {raw:.2f} CPU-s, denoised {on:.2f}; filter ({what}) {cost:.2f} CPU-s = {cost / raw:.2f} x the raw bake")
EOF
