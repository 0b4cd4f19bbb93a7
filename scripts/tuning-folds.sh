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
# Outputs: out/folds/SET/FOLD/ (sites, maps) and out/folds/SET-eval/NAME/.
set -euo pipefail
cd "$(dirname "$0")/.."
F=${FPBP:-target/release/fpbp}
D=${FPBP_DATASETS:-../shared/datasets}
floor=()
usage="usage: tuning-folds.sh build f1|f4|ipin | eval f1|f4|ipin NAME ENGINE SEEDS [EVAL ARGS...]"
mode=${1:?$usage}
set_=${2:?$usage}
case $set_ in
f1)
    mapfile -t ALL < <(ls "$D"/ilc/site1/F1/path_data_files/*.txt.gz | sort)
    site=out/sites/ilc-site1-F1/site.json
    folds=(0 1 2 3 4 5 6 7 8 9 10 11 12)
    ;;
f4)
    mapfile -t ALL < <(ls "$D"/ilc/site2/F4/path_data_files/*.txt.gz | sort)
    site=out/sites/ilc-site2-F4/site.json
    folds=(0 1 2 3 4 5 6 7 8 9 10 11 12)
    floor=(--floor 4)
    ;;
ipin)
    mapfile -t ALL < <(ls "$D"/ipin2023/logs/*.txt.gz | sort)
    site=out/sites/ipin2023/site.json
    folds=()
    for T in 01 02 03 04 21 22 23 24 25 26; do folds+=("$T-A" "$T-B"); done
    ;;
*)
    echo "$usage" >&2
    exit 2
    ;;
esac
[ -f "$site" ] || { echo "missing $site: run the imports of docs/sites.md" >&2; exit 1; }
N=${#ALL[@]}
root=out/folds/$set_

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
    printf '%s\n' "${test[@]}" >"$dir/test.txt"
    printf '%s\n' "${train[@]}" >"$dir/train.txt"
}

if [ "$mode" = build ]; then
    for G in "${folds[@]}"; do
        o=$root/$G
        mkdir -p "$o"
        split_logs "$G" "$o"
        mapfile -t train <"$o/train.txt"
        "$F" calibrate --site "$site" --logs "${train[@]}" --split all --wifi "${floor[@]}" \
            --out "$o/site-wifi.json" --radio-map "$o/radio-map.json" >"$o/calib.txt" 2>&1 ||
            { echo "calibrate failed: $o/calib.txt" >&2; exit 1; }
        echo "$G: ${#train[@]} survey logs, $(wc -l <"$o/test.txt") test logs"
    done
    exit 0
fi
[ "$mode" = eval ] || { echo "$usage" >&2; exit 2; }
name=${3:?$usage}
engine=${4:?$usage}
seeds=${5:?$usage}
shift 5
out=out/folds/$set_-eval/$name
mkdir -p "$out"
for G in "${folds[@]}"; do
    o=$root/$G
    [ -f "$o/radio-map.json" ] || { echo "missing $o: run build first" >&2; exit 1; }
    mapfile -t test <"$o/test.txt"
    rm=(--radio-map "$o/radio-map.json")
    [ "${RADIO_MAP:-1}" = 0 ] && rm=()
    "$F" eval --site "$o/site-wifi.json" --logs "${test[@]}" --split all \
        "${rm[@]}" --engine "$engine" --seeds "$seeds" "${floor[@]}" "$@" \
        --out "$out/$G" >"$out.$G.log" 2>&1 || {
        # eval exits non-zero when an engine positioned nothing; its
        # points.csv (every point without a pose) still counts
        compgen -G "$out/$G/seed-*/points.csv" >/dev/null ||
            { echo "eval failed: $out.$G.log" >&2; exit 1; }
        echo "warning: $G: $(grep -m1 '^error' "$out.$G.log")" >&2
    }
done
python3 - "$out" "$set_" <<'EOF'
import csv, glob, os, sys
from collections import defaultdict
out, set_ = sys.argv[1], sys.argv[2]
kinds = {"": "*"} if set_ != "ipin" else {"A ": "*-A", "B ": "*-B"}
for label, pat in kinds.items():
    by = defaultdict(list)
    for d in sorted(glob.glob(f"{out}/{pat}")):
        if not os.path.isdir(d):
            continue
        for sd in glob.glob(f"{d}/seed-*"):
            for r in csv.DictReader(open(f"{sd}/points.csv")):
                e, a = r["error_m"], r["accuracy_m"]
                by[(r["engine"], os.path.basename(sd))].append(
                    (float(e), float(a) if a else None) if e else None)
    for eng in sorted({e for e, _ in by}):
        means, cov, p80, inacc, n = [], [], [], [], 0
        for (e, seed), es in sorted(by.items()):
            if e != eng:
                continue
            ok = sorted(x[0] for x in es if x is not None)
            acc = [x for x in es if x is not None and x[1] is not None]
            means.append(sum(ok) / len(ok))
            p80.append(ok[min(len(ok) - 1, int(0.8 * len(ok)))])
            cov.append(len(ok) / len(es))
            inacc.append(sum(x[0] <= x[1] for x in acc) / max(1, len(acc)))
            n = len(es)
        avg = lambda xs: sum(xs) / len(xs)
        print(f"{label}{eng}: mean {avg(means):.2f} m, p80 {avg(p80):.2f} m, coverage "
              f"{100 * avg(cov):.0f} %, in_acc {100 * avg(inacc):.0f} %, "
              f"seeds {' '.join(f'{m:.2f}' for m in means)}, {n} points")
EOF
