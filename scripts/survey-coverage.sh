#!/usr/bin/env bash
# How much of a held-out figure comes from the survey having walked the test
# route (docs/lab/tcpf-history.md "Stop 34: what the held-out halves measure").
#
# The shared logs' even / odd split interleaves recordings that belong
# together: ILC site1/F1 paths are cuts of one continuous session (path i+1
# starts a median 15 s after path i ended, 10.6 m further on), and each
# IPIN 2023 training trial is one route walked four times (repetitions 1 and
# 3 fall in the even half, 2 and 4 in the odd). So every odd walk has its
# own session or route in the survey half. This script scores the odd walks
# again with a survey that lacks that, against a control of the same size:
#
#   f1   A: even half minus each test path's two neighbours (i - 1, i + 1);
#        B: even half minus the paths three away (i - 3, i + 3) instead.
#        Test paths: the odd ones, 8 groups (sorted index = r mod 16).
#   ipin A: even half minus the test trial's own repetitions;
#        B: even half minus the next trial's repetitions instead.
#        Test logs: the odd repetitions of one trial, 10 groups.
#
# Usage (repository root, after `cargo build --release -p fpbp-cli` and the
# site imports of docs/sites.md, which write out/sites/):
#   scripts/survey-coverage.sh build f1|ipin      # sites and radio maps per group
#   scripts/survey-coverage.sh eval f1|ipin NAME ENGINE SEEDS [EVAL ARGS...]
#       e.g. scripts/survey-coverage.sh eval f1 own tcpf 1-5
#            scripts/survey-coverage.sh eval f1 truth tcpf 1-5 --init truth
# eval prints, per variant, the mean error over the pooled points of every
# group (mean of the per-seed means), coverage and the per-seed means.
# Outputs: out/coverage/SET/{A,B}-GROUP/ (sites, maps) and
# out/coverage/SET-eval/NAME/{A,B}-GROUP/ (fpbp eval folders); SET-VARIANT
# with FOLDS_VARIANT (scripts/lib/folds.sh: folds built with other
# calibrate settings).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib/folds.sh
usage="usage: survey-coverage.sh build f1|ipin | eval f1|ipin NAME ENGINE SEEDS [EVAL ARGS...]"
mode=${1:?$usage}
set_=${2:?$usage}
logs_of_set "$set_" || { echo "$usage" >&2; exit 2; }
case $set_ in
f1) groups=(1 3 5 7 9 11 13 15) ;;
ipin) groups=(01 02 03 04 21 22 23 24 25 26) ;;
*) echo "$usage" >&2 && exit 2 ;;
esac
N=${#ALL[@]}
root=out/coverage/$set_$VARIANT

# test and training logs of variant V (A or B) of group G, one per line, into DIR
split_logs() {
    local V=$1 G=$2 dir=$3 i j d
    local -a test=() train=()
    if [ "$set_" = f1 ]; then
        d=$([ "$V" = A ] && echo 1 || echo 3)
        local drop=" "
        for ((i = G; i < N; i += 16)); do
            test+=("${ALL[$i]}")
            drop+="$((i - d)) $((i + d)) "
        done
        for ((j = 0; j < N; j += 2)); do
            [[ "$drop" == *" $j "* ]] || train+=("${ALL[$j]}")
        done
    else
        local k out
        # B leaves out the next trial in the list (the last: the first)
        for k in "${!groups[@]}"; do [ "${groups[$k]}" = "$G" ] && break; done
        out=$([ "$V" = A ] && echo "$G" || echo "${groups[$(((k + 1) % ${#groups[@]}))]}")
        for ((i = 0; i < N; i++)); do
            local f=${ALL[$i]}
            if ((i % 2 == 1)); then
                [[ $f == *Trial${G}_* ]] && test+=("$f")
            else
                [[ $f == *Trial${out}_* ]] || train+=("$f")
            fi
        done
    fi
    write_split "$dir"
}

if [ "$mode" = build ]; then
    for G in "${groups[@]}"; do
        for V in A B; do
            o=$root/$V-$G
            mkdir -p "$o"
            split_logs "$V" "$G" "$o"
            calibrate_fold "$o"
        done
    done
    exit 0
fi
eval_args "$@"
out=out/coverage/$set_$VARIANT-eval/$name
mkdir -p "$out"
for V in A B; do
    for G in "${groups[@]}"; do
        eval_fold "$root/$V-$G" "$out/$V-$G" "$engine" "$seeds" "${extra[@]}"
    done
done
python3 scripts/lib/pool_points.py "$out" "A=A-*" "B=B-*"
