#!/usr/bin/env bash
# The error budget of engine tcpf (docs/tcpf.md "Error budget: where the
# metres go"): mean error by time since the start (0-15, 15-30, 30-60,
# 60-120, 120+ s) of tcpf from its own start and from a known start
# (`--init truth`), beside the walk alone (`pdr`, known start) and the
# fingerprint with no memory (`scan-knn`), on
#   - the tuning protocol's sets (scripts/route-held-out.sh: routes the
#     survey never walked, routes it walked) and its check set (ILC F4);
#   - the two floors no default was tuned on (ILC site1/F3, site2/F1: odd
#     half scored, even half surveyed);
# with one part replaced by its oracle where one is built:
#   - the map: the odd halves scored with a map calibrated on the odd half
#     itself (every scored scan is a reference scan: an upper bound);
#   - the phone's WiFi as Android 9+ gives a foreground app
#     (`--radios ble,wifi-throttled`, known start), beside all WiFi;
# and the radio alone: how long `scan-knn`'s error lasts along a walk
# (its autocorrelation by seconds and metres walked, scripts/lib/time_bins.py).
#
# Usage (repository root, after `cargo build --release -p fpbp-cli` and
# `scripts/route-held-out.sh build`):
#   scripts/error-budget.sh [SEEDS]        (SEEDS default 1-5; ~6 min on 2 cores)
#   TABLES=1 scripts/error-budget.sh      the tables and plots of the last run
# Writes out/budget/budget.md (the tables) and out/budget/error-budget-*.svg
# (the plots); docs/tcpf.md "Error budget" carries a copy of both (the
# plots in docs/img/).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib/folds.sh
seeds=${1:-1-5}
out=out/budget
mkdir -p "$out"

# TABLES=1: only the tables and plots of the last run
if [ "${TABLES:-0}" != 1 ]; then
# the new floors and the oracle maps
for s in f3 s2f1; do
    case $s in f3) src=site1/F3 dst=ilc-site1-F3 ;; s2f1) src=site2/F1 dst=ilc-site2-F1 ;; esac
    [ -f "out/sites/$dst/site.json" ] || "$F" import ilc "$D/ilc/$src" --out "out/sites/$dst" >/dev/null
    [ -f "$(odd_dir $s)/radio-map.json" ] || build_odd $s
done
for s in ipin f1 f3 s2f1; do
    dir=out/oracle/$s
    if [ ! -f "$dir/radio-map.json" ]; then
        mkdir -p "$dir"
        logs_of_set $s
        cp "$(odd_dir $s)/test.txt" "$dir/test.txt"
        cp "$(odd_dir $s)/test.txt" "$dir/train.txt"
        calibrate_fold "$dir"
    fi
done

# the evals
echo "== protocol sets, both starts" >&2
STARTS="own truth" scripts/route-held-out.sh eval budget tcpf,scan-knn,pdr "$seeds" >/dev/null
STARTS="own truth" scripts/route-held-out.sh check budget tcpf "$seeds" >/dev/null
for s in f3 s2f1; do
    echo "== $s odd half, both starts" >&2
    mkdir -p "$(odd_dir $s)-eval/budget-own" "$(odd_dir $s)-eval/budget-truth"
    eval_fold "$(odd_dir $s)" "$(odd_dir $s)-eval/budget-own/odd" tcpf,scan-knn,pdr "$seeds"
    eval_fold "$(odd_dir $s)" "$(odd_dir $s)-eval/budget-truth/odd" tcpf "$seeds" --init truth
done
for s in ipin f1 f3 s2f1; do
    echo "== $s odd half: the oracle map; the phone's WiFi" >&2
    mkdir -p "out/oracle/$s-eval"
    eval_fold "out/oracle/$s" "out/oracle/$s-eval/own" tcpf,scan-knn "$seeds"
    eval_fold "out/oracle/$s" "out/oracle/$s-eval/truth" tcpf "$seeds" --init truth
    mkdir -p "$(odd_dir $s)-eval/budget-throttled"
    eval_fold "$(odd_dir $s)" "$(odd_dir $s)-eval/budget-throttled/odd" tcpf "$seeds" --init truth \
        --radios ble,wifi-throttled
done
fi

# the tables
P=out/protocol
rows=()
add() { rows+=("$1|$2|$3|$4|$5"); }
for start in own truth; do
    e=tcpf
    [ $start = own ] && e=tcpf,scan-knn
    [ $start = truth ] && e=tcpf,pdr
    add "IPIN T-A (held out)" "$start" out/folds/ipin-eval/budget-$start "*-A" $e
    add "IPIN coverage A (held out)" "$start" out/coverage/ipin-eval/budget-$start "A-*" $e
    add "ILC F1 coverage A (held out)" "$start" out/coverage/f1-eval/budget-$start "A-*" $e
    add "ILC F4 odd (held out, check)" "$start" "$(odd_dir f4)-eval/check-budget-$start" odd $e
    add "IPIN T-B (surveyed)" "$start" out/folds/ipin-eval/budget-$start "*-B" $e
    add "IPIN coverage B (surveyed)" "$start" out/coverage/ipin-eval/budget-$start "B-*" $e
    add "ILC F1 coverage B (surveyed)" "$start" out/coverage/f1-eval/budget-$start "B-*" $e
    add "IPIN odd (surveyed)" "$start" "$(odd_dir ipin)-eval/budget-$start" odd $e
    add "ILC F1 odd (surveyed)" "$start" "$(odd_dir f1)-eval/budget-$start" odd $e
    # pdr (always from the known start) ran beside the own start here
    for s in f3 s2f1; do
        l="ILC site1/F3 odd (new floor)"
        [ $s = s2f1 ] && l="ILC site2/F1 odd (new floor)"
        if [ $start = own ]; then
            add "$l" own "$(odd_dir $s)-eval/budget-own" odd tcpf,scan-knn
        else
            add "$l" truth "$(odd_dir $s)-eval/budget-truth" odd tcpf
            add "$l" truth "$(odd_dir $s)-eval/budget-own" odd pdr
        fi
    done
done
oracle=()
for s in ipin f1 f3 s2f1; do
    oracle+=("$s odd|oracle map, own|out/oracle/$s-eval|own|tcpf,scan-knn"
        "$s odd|oracle map, truth|out/oracle/$s-eval|truth|tcpf"
        "$s odd|phone WiFi, truth|$(odd_dir $s)-eval/budget-throttled|odd|tcpf")
done
knn=()
for r in "${rows[@]}"; do
    case $r in *"|own|"*) knn+=("$r") ;; esac
done
{
    echo "## Error by time since start (engine seeds $seeds)"
    echo
    python3 scripts/lib/time_bins.py "${rows[@]}"
    echo
    echo "## Oracles and the phone's WiFi"
    echo
    python3 scripts/lib/time_bins.py "${oracle[@]}"
    echo
    echo "## How long the radio's error lasts (scan-knn)"
    echo
    python3 scripts/lib/time_bins.py --autocorr scan-knn "${knn[@]}"
} | tee "$out/budget.md"
# the plots: a route the survey never walked, and a floor no default was
# tuned on with every variant
python3 scripts/lib/time_bins.py --svg "$out/error-budget-ipin-t-a.svg" \
    "IPIN T-A|own|out/folds/ipin-eval/budget-own|*-A|tcpf,scan-knn" \
    "IPIN T-A|known|out/folds/ipin-eval/budget-truth|*-A|tcpf,pdr" >/dev/null
n="$(odd_dir s2f1)-eval"
python3 scripts/lib/time_bins.py --svg "$out/error-budget-site2-f1.svg" \
    "site2/F1|own|$n/budget-own|odd|tcpf,scan-knn" "site2/F1|known|$n/budget-truth|odd|tcpf" \
    "site2/F1|known|$n/budget-own|odd|pdr" \
    "site2/F1|oracle map, own|out/oracle/s2f1-eval|own|tcpf" \
    "site2/F1|oracle map, known|out/oracle/s2f1-eval|truth|tcpf" \
    "site2/F1|phone WiFi, known|$n/budget-throttled|odd|tcpf" >/dev/null
