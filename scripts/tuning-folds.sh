#!/usr/bin/env bash
# Folds of the tuning halves, for choosing a parameter without touching the
# held-out halves (docs/parameters.md says which figures came from these).
#
# Only the even half of each set is used: every fold is scored with a site
# and radio map calibrated on the rest of the even half (`fpbp calibrate
# --split all --wifi --radio-map`), so no fold sees its own walks.
#
#   f1    ILC site1/F1: the even paths (sorted), fold G of 13 = the paths
#         E[j] with j mod 13 = G; survey: the other even paths. (F1 paths
#         are cuts of one session: a test path's session neighbours are odd
#         paths, left out; the even paths two away stay in the survey.)
#   f4    ILC site2/F4 (BLE-poor, floor 4): the 13 even paths, one fold per
#         path (leave one out); survey: the other even paths.
#   ipin  IPIN 2023: for each training trial T, two folds: T-A scores T's
#         even repetitions with a survey lacking the whole trial (a route
#         never surveyed); T-B scores T's repetition 3 with a survey that
#         keeps repetition 1 (the route surveyed once, as in the held-out
#         half).
#
# Usage (repository root, after `cargo build --release -p fpbp-cli` and the
# site imports of docs/sites.md, which write out/sites/):
#   scripts/tuning-folds.sh build f1|f4|ipin
#   scripts/tuning-folds.sh eval f1|f4|ipin NAME ENGINE SEEDS [EVAL ARGS...]
#       e.g. scripts/tuning-folds.sh eval f1 own tcpf 1-3
#            scripts/tuning-folds.sh eval ipin truth tcpf 1-3 --init truth
# RADIO_MAP=0 scores without the radio map (tcpf on the fold's path-loss
# model). eval prints the mean error over the pooled points of the folds (mean of
# the per-seed means; IPIN: A and B folds apart), coverage, p80 and the
# share of points within the accuracy radius.
# Outputs: out/folds/SET/FOLD/ (sites, maps) and out/folds/SET-eval/NAME/;
# SET-VARIANT with FOLDS_VARIANT (scripts/lib/folds.sh: folds built with
# other calibrate settings).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib/folds.sh
usage="usage: tuning-folds.sh build f1|f4|ipin | eval f1|f4|ipin NAME ENGINE SEEDS [EVAL ARGS...]"
mode=${1:?$usage}
set_=${2:?$usage}
logs_of_set "$set_" || { echo "$usage" >&2; exit 2; }
floor=()
case $set_ in
f1) folds=(0 1 2 3 4 5 6 7 8 9 10 11 12) ;;
f4)
    folds=(0 1 2 3 4 5 6 7 8 9 10 11 12)
    floor=(--floor 4)
    ;;
ipin)
    folds=()
    for T in 01 02 03 04 21 22 23 24 25 26; do folds+=("$T-A" "$T-B"); done
    ;;
esac
N=${#ALL[@]}
root=out/folds/$set_$VARIANT

# test and survey logs of fold G, one per line, into DIR
split_logs() {
    local G=$1 dir=$2 i f
    local -a test=() train=()
    if [ "$set_" != ipin ]; then
        for ((i = 0; i < N; i += 2)); do
            if (((i / 2) % 13 == G)); then test+=("${ALL[$i]}"); else train+=("${ALL[$i]}"); fi
        done
    else
        local T=${G%-*} V=${G#*-}
        for ((i = 0; i < N; i += 2)); do
            f=${ALL[$i]}
            if [[ $f == *Trial${T}_* ]]; then
                if [ "$V" = A ] || [[ $f == *repetition03* ]]; then test+=("$f"); else train+=("$f"); fi
            else
                train+=("$f")
            fi
        done
    fi
    write_split "$dir"
}

if [ "$mode" = build ]; then
    for G in "${folds[@]}"; do
        o=$root/$G
        mkdir -p "$o"
        split_logs "$G" "$o"
        calibrate_fold "$o" "${floor[@]}"
    done
    exit 0
fi
eval_args "$@"
out=out/folds/$set_$VARIANT-eval/$name
mkdir -p "$out"
for G in "${folds[@]}"; do
    eval_fold "$root/$G" "$out/$G" "$engine" "$seeds" "${floor[@]}" "${extra[@]}"
done
if [ "$set_" = ipin ]; then
    python3 scripts/lib/pool_points.py "$out" "A=*-A" "B=*-B"
else
    python3 scripts/lib/pool_points.py "$out" "=*"
fi
