#!/usr/bin/env bash
# Mean error of one engine config on the fusion tuning or held-out sets
# (docs/lab/fusion-sessions.md "Session 4"): one line per call, for parameter sweeps.
#
# Usage (from the repository root, after `cargo build --release -p fpbp-cli`
# and the site imports of docs/sites.md):
#   scripts/fusion-sets.sh logs                 # writes the 24 tuning logs to out/tune/
#   scripts/fusion-sets.sh tune  NAME CONFIG_JSON [ENGINE]
#   scripts/fusion-sets.sh check NAME CONFIG_JSON [ENGINE]
#   scripts/fusion-sets.sh seeds NAME CONFIG_JSON [ENGINE] [N]
# tune:  24 simulated logs (seeds 11-34) own start and --init truth, ILC
#        site1/F1 even paths --init truth and own start, IPIN even --init truth.
# check: the shipped logs own / truth, ILC F1 odd truth / own, ILC F4 odd
#        truth, IPIN odd truth (held out: never used to choose a default).
# seeds: the shipped and the 24 tuning logs, own start and --init truth,
#        each the mean over engine seeds 1..N (default 5): a log's error
#        moves by ~0.3 m with the seed, so one seed cannot rank configs.
# Outputs go to out/sets/NAME/. ENGINE defaults to fpbp.
set -euo pipefail
cd "$(dirname "$0")/.."
F=${FPBP:-target/release/fpbp}
D=${FPBP_DATASETS:-../shared/datasets}
mode=${1:?usage: fusion-sets.sh logs|tune|check|seeds NAME CONFIG_JSON [ENGINE] [N]}
if [ "$mode" = logs ]; then
    mkdir -p out/tune
    for s in $(seq 11 34); do
        profile=default
        [ $((s % 3)) -eq 0 ] && profile=swinging
        "$F" simulate --site maps/demo/site.json --seconds 120 --seed "$s" \
            --profile $profile --out out/tune/sim-$s.log.gz >/dev/null
    done
    echo "24 tuning logs in out/tune"
    exit 0
fi
name=${2:?NAME}
cfg=${3:?CONFIG_JSON}
eng=${4:-fpbp}
# CONFIG_JSON is JSON text or the path of a JSON file
if [ -f "$cfg" ]; then
    cfg=$(cat "$cfg")
fi
case $cfg in
\{*) ;;
*)
    echo "CONFIG_JSON must be JSON text ({...}) or an existing file, got: ${cfg:0:80}" >&2
    exit 2
    ;;
esac
if [ "$mode" = seeds ]; then
    n=${5:-5}
    o=out/sets/$name
    mkdir -p "$o"
    echo "$cfg" >"$o/config.json"
    printf '%-20s' "$name"
    for set in shipped_own shipped_truth sim24_own sim24_truth; do
        case $set in shipped*) logs=(host-tests/logs/*.gz) ;; *) logs=(out/tune/*.gz) ;; esac
        init=()
        case $set in *truth) init=(--init truth) ;; esac
        mean=$(for s in $(seq 1 "$n"); do
            "$F" eval --site maps/demo/site.json --logs "${logs[@]}" --engine "$eng" \
                --config "$o/config.json" --seed "$s" "${init[@]}" --out "$o/seeds" 2>/dev/null |
                awk -v e="$eng" '$1 == e {print $5}'
        done | awk '{t += $1; k++} END {if (k) printf "%.3f", t / k}')
        printf ' %s %s' "$set" "$mean"
    done
    printf '   (seeds 1-%s) %s\n' "$n" "$cfg"
    exit 0
fi
[ -d "$D" ] || { echo "skipped: $D not found (the real-data sets need it)" >&2; exit 1; }
o=out/sets/$name
mkdir -p "$o"
echo "$cfg" >"$o/config.json"
F1=out/sites/ilc-site1-F1/site-cal.json
F4=out/sites/ilc-site2-F4/site.json
IP=out/sites/ipin2023/site.json
for site in $F1 $F4 $IP; do
    [ -f "$site" ] || {
        echo "$site not found: make the real sites first (docs/sites.md)" >&2
        exit 1
    }
done
run() { # label site split init logs...
    local label=$1 site=$2 split=$3 init=$4
    shift 4
    local extra=()
    [ "$split" != all ] && extra+=(--split "$split")
    [ "$init" = truth ] && extra+=(--init truth)
    if ! "$F" eval --site "$site" --logs "$@" --engine "$eng" --config "$o/config.json" \
        "${extra[@]}" --out "$o/$label" >"$o/$label.txt" 2>&1; then
        echo >&2
        echo "eval $label failed (see $o/$label.txt):" >&2
        tail -5 "$o/$label.txt" >&2
        exit 1
    fi
    printf ' %s %s' "$label" "$(awk -v e="$eng" '$1 == e {print $5}' "$o/$label.txt")"
}
printf '%-20s' "$name"
case $mode in
tune)
    run sim24_own maps/demo/site.json all own out/tune/*.gz
    run sim24_truth maps/demo/site.json all truth out/tune/*.gz
    run f1_even_truth $F1 even truth $D/ilc/site1/F1/path_data_files/*.txt.gz
    run f1_even_own $F1 even own $D/ilc/site1/F1/path_data_files/*.txt.gz
    run ipin_even_truth $IP even truth $D/ipin2023/logs/*.gz
    ;;
check)
    run shipped_own maps/demo/site.json all own host-tests/logs/*.gz
    run shipped_truth maps/demo/site.json all truth host-tests/logs/*.gz
    run f1_odd_truth $F1 odd truth $D/ilc/site1/F1/path_data_files/*.txt.gz
    run f1_odd_own $F1 odd own $D/ilc/site1/F1/path_data_files/*.txt.gz
    run f4_odd_truth $F4 odd truth $D/ilc/site2/F4/path_data_files/*.txt.gz
    run ipin_odd_truth $IP odd truth $D/ipin2023/logs/*.gz
    ;;
*)
    echo "unknown mode $mode (logs, tune, check or seeds)" >&2
    exit 2
    ;;
esac
printf '   %s\n' "$cfg"
