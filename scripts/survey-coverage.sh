#!/usr/bin/env bash
# How much of a held-out figure comes from the survey having walked the test
# route (docs/tcpf.md "Stop 34: what the held-out halves measure").
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
# out/coverage/SET-eval/NAME/{A,B}-GROUP/ (fpbp eval folders).
set -euo pipefail
cd "$(dirname "$0")/.."
F=${FPBP:-target/release/fpbp}
D=${FPBP_DATASETS:-../shared/datasets}
usage="usage: survey-coverage.sh build f1|ipin | eval f1|ipin NAME ENGINE SEEDS [EVAL ARGS...]"
mode=${1:?$usage}
set_=${2:?$usage}
case $set_ in
f1)
    mapfile -t ALL < <(ls "$D"/ilc/site1/F1/path_data_files/*.txt.gz | sort)
    site=out/sites/ilc-site1-F1/site.json
    groups=(1 3 5 7 9 11 13 15)
    ;;
ipin)
    mapfile -t ALL < <(ls "$D"/ipin2023/logs/*.txt.gz | sort)
    site=out/sites/ipin2023/site.json
    groups=(01 02 03 04 21 22 23 24 25 26)
    ;;
*)
    echo "$usage" >&2
    exit 2
    ;;
esac
[ -f "$site" ] || { echo "missing $site: run the imports of docs/sites.md" >&2; exit 1; }
N=${#ALL[@]}
root=out/coverage/$set_

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
    printf '%s\n' "${test[@]}" >"$dir/test.txt"
    printf '%s\n' "${train[@]}" >"$dir/train.txt"
}

if [ "$mode" = build ]; then
    for G in "${groups[@]}"; do
        for V in A B; do
            o=$root/$V-$G
            mkdir -p "$o"
            split_logs "$V" "$G" "$o"
            mapfile -t train <"$o/train.txt"
            "$F" calibrate --site "$site" --logs "${train[@]}" --split all --wifi \
                --out "$o/site-wifi.json" --radio-map "$o/radio-map.json" >"$o/calib.txt" 2>&1 ||
                { echo "calibrate failed: $o/calib.txt" >&2; exit 1; }
            echo "$V-$G: ${#train[@]} survey logs, $(wc -l <"$o/test.txt") test logs"
        done
    done
    exit 0
fi
[ "$mode" = eval ] || { echo "$usage" >&2; exit 2; }
name=${3:?$usage}
engine=${4:?$usage}
seeds=${5:?$usage}
shift 5
out=out/coverage/$set_-eval/$name
mkdir -p "$out"
for V in A B; do
    for G in "${groups[@]}"; do
        o=$root/$V-$G
        [ -f "$o/radio-map.json" ] || { echo "missing $o: run build first" >&2; exit 1; }
        mapfile -t test <"$o/test.txt"
        "$F" eval --site "$o/site-wifi.json" --logs "${test[@]}" --split all \
            --radio-map "$o/radio-map.json" --engine "$engine" --seeds "$seeds" "$@" \
            --out "$out/$V-$G" >"$out.$V-$G.log" 2>&1 || {
            # eval exits non-zero when an engine positioned nothing; its
            # points.csv (every point without a pose) still counts
            compgen -G "$out/$V-$G/seed-*/points.csv" >/dev/null ||
                { echo "eval failed: $out.$V-$G.log" >&2; exit 1; }
            echo "warning: $V-$G: $(grep -m1 '^error' "$out.$V-$G.log")" >&2
        }
    done
done
python3 - "$out" <<'EOF'
import csv, glob, os, sys
from collections import defaultdict
out = sys.argv[1]
for v in "AB":
    by = defaultdict(list)
    for d in sorted(glob.glob(f"{out}/{v}-*")):
        for sd in glob.glob(f"{d}/seed-*"):
            for r in csv.DictReader(open(f"{sd}/points.csv")):
                e = r["error_m"]
                by[(r["engine"], os.path.basename(sd))].append(float(e) if e else None)
    for eng in sorted({e for e, _ in by}):
        means, cov = [], []
        for (e, seed), es in sorted(by.items()):
            if e != eng:
                continue
            ok = [x for x in es if x is not None]
            means.append(sum(ok) / len(ok))
            cov.append(len(ok) / len(es))
        print(f"{v} {eng}: mean {sum(means) / len(means):.2f} m, coverage "
              f"{100 * sum(cov) / len(cov):.0f} %, seeds {' '.join(f'{m:.2f}' for m in means)}, "
              f"{len(es)} points")
EOF
