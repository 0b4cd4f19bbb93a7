#!/usr/bin/env bash
# The tuning protocol of engine tcpf in one command (docs/tcpf.md "Tuning
# protocol: routes the survey never walked"): a default is chosen on the
# sets whose scored routes the survey never walked, with the sets whose
# routes it walked beside them; a change that wins on the second and loses
# on the first is not taken.
#
#   route held out  IPIN never-surveyed routes (scripts/tuning-folds.sh ipin,
#                   folds T-A: a trial's even repetitions, survey without
#                   the trial);
#                   IPIN survey without the route (scripts/survey-coverage.sh
#                   ipin A: a trial's odd repetitions, survey = the even
#                   half without the trial);
#                   ILC F1 survey without the walk's session neighbours
#                   (scripts/survey-coverage.sh f1 A).
#   surveyed        IPIN T-B, IPIN survey-coverage B, ILC F1 survey-coverage B
#                   (the controls of the same size: another trial's or
#                   further paths left out instead), and the odd halves of
#                   IPIN and ILC F1 with the even half's site and radio map
#                   (docs/tcpf.md "Current figures").
#   check set       ILC site2/F4 odd with the even half's site and radio map:
#                   its test waypoints lie a median 16.5 m from the survey's
#                   (a route the survey did not walk). No default is chosen
#                   on it: `check` scores a default once it is chosen, so a
#                   figure not tuned on stands beside the protocol's.
#
# Usage (repository root, after `cargo build --release -p fpbp-cli`):
#   scripts/route-held-out.sh build
#       imports the three sites into out/sites/ (when missing) and calibrates
#       every fold's site and radio map (~10 min on 2 cores)
#   scripts/route-held-out.sh eval NAME [ENGINES] [SEEDS] [EVAL ARGS...]
#       e.g. scripts/route-held-out.sh eval defaults
#            scripts/route-held-out.sh eval fit5 tcpf 1-5 --config fit5.json
#            STARTS=truth scripts/route-held-out.sh eval base pdr,tcpf,scan-knn
#       ENGINES default tcpf, SEEDS default 1-5 (one seed moves a set's
#       mean by +-0.2 m). Every set from the engine's own start and from
#       the true start (`--init truth`; STARTS="own", "truth" or "own
#       truth"). Prints a Markdown table (mean, coverage, share within the
#       accuracy radius, p80, each seed's mean) and the mean of the set
#       means over the held-out and over the surveyed sets; also written to
#       out/protocol/NAME.md.
#   scripts/route-held-out.sh check NAME [ENGINES] [SEEDS] [EVAL ARGS...]
#       the check set, both starts (STARTS as for eval), with `pdr` and
#       `scan-knn` beside ENGINES (`pdr` always from the true start);
#       out/protocol/check-NAME.md. Not for
#       choosing between variants: run it on the one chosen.
# RADIO_MAP=0 scores without the radio maps (tcpf on each fold's path-loss
# model); FOLDS_VARIANT as in scripts/lib/folds.sh (folds built with other
# `fpbp calibrate` settings).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib/folds.sh
usage="usage: route-held-out.sh build | eval|check NAME [ENGINES] [SEEDS] [EVAL ARGS...]"
mode=${1:?$usage}

if [ "$mode" = build ]; then
    [ -f out/sites/ilc-site1-F1/site.json ] ||
        "$F" import ilc "$D/ilc/site1/F1" --out out/sites/ilc-site1-F1 >/dev/null
    [ -f out/sites/ipin2023/site.json ] ||
        "$F" import ipin "$D/ipin2023" --out out/sites/ipin2023 >/dev/null
    scripts/tuning-folds.sh build ipin
    scripts/survey-coverage.sh build ipin
    scripts/survey-coverage.sh build f1
    build_odd ipin
    build_odd f1
    [ -f out/sites/ilc-site2-F4/site.json ] ||
        "$F" import ilc "$D/ilc/site2/F4" --out out/sites/ilc-site2-F4 >/dev/null
    build_odd f4
    exit 0
fi
case $mode in eval | check) ;; *) echo "$usage" >&2 && exit 2 ;; esac
# init_of START: the eval arguments of a start (own or truth) into init.
init_of() {
    case $1 in
    own) init=() ;;
    truth) init=(--init truth) ;;
    *) echo "STARTS: own and / or truth, not $1" >&2 && exit 2 ;;
    esac
}
name=${2:?$usage}
engines=${3:-tcpf}
seeds=${4:-1-5}
extra=("${@:5}")
V=$VARIANT
rows=()
if [ "$mode" = check ]; then
    for start in ${STARTS:-own truth}; do
        init_of "$start"
        n=check-$name-$start
        echo "== $start start: ILC F4 odd half (check set)" >&2
        mkdir -p "$(odd_dir f4)-eval/$n"
        beside=pdr,scan-knn
        [ "${RADIO_MAP:-1}" = 0 ] && beside=pdr # scan-knn needs the radio map
        eval_fold "$(odd_dir f4)" "$(odd_dir f4)-eval/$n/odd" "$engines,$beside" "$seeds" \
            "${init[@]}" "${extra[@]}"
        rows+=("ILC F4 odd half (check set, not tuned on)|held out|$start|$(odd_dir f4)-eval/$n|odd")
    done
    mkdir -p out/protocol
    python3 scripts/lib/protocol_table.py "${rows[@]}" | tee "out/protocol/check-$name.md"
    exit 0
fi
for start in ${STARTS:-own truth}; do
    init_of "$start"
    n=$name-$start
    echo "== $start start: IPIN tuning folds" >&2
    scripts/tuning-folds.sh eval ipin "$n" "$engines" "$seeds" "${init[@]}" "${extra[@]}" >/dev/null
    echo "== $start start: IPIN survey coverage" >&2
    scripts/survey-coverage.sh eval ipin "$n" "$engines" "$seeds" "${init[@]}" "${extra[@]}" >/dev/null
    echo "== $start start: ILC F1 survey coverage" >&2
    scripts/survey-coverage.sh eval f1 "$n" "$engines" "$seeds" "${init[@]}" "${extra[@]}" >/dev/null
    for s in ipin f1; do
        echo "== $start start: $s odd half" >&2
        mkdir -p "$(odd_dir "$s")-eval/$n"
        eval_fold "$(odd_dir "$s")" "$(odd_dir "$s")-eval/$n/odd" "$engines" "$seeds" "${init[@]}" "${extra[@]}"
    done
    rows+=(
        "IPIN never-surveyed routes (T-A)|held out|$start|out/folds/ipin$V-eval/$n|*-A"
        "IPIN survey without the route (coverage A)|held out|$start|out/coverage/ipin$V-eval/$n|A-*"
        "ILC F1 survey without the session neighbours (coverage A)|held out|$start|out/coverage/f1$V-eval/$n|A-*"
        "IPIN route surveyed once (T-B)|surveyed|$start|out/folds/ipin$V-eval/$n|*-B"
        "IPIN coverage B|surveyed|$start|out/coverage/ipin$V-eval/$n|B-*"
        "ILC F1 coverage B|surveyed|$start|out/coverage/f1$V-eval/$n|B-*"
        "IPIN odd half|surveyed|$start|$(odd_dir ipin)-eval/$n|odd"
        "ILC F1 odd half|surveyed|$start|$(odd_dir f1)-eval/$n|odd"
    )
done
mkdir -p out/protocol
python3 scripts/lib/protocol_table.py "${rows[@]}" | tee "out/protocol/$name.md"
