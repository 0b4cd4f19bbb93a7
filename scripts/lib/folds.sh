# Shared by scripts/survey-coverage.sh and scripts/tuning-folds.sh (sourced,
# from the repository root): fold folders hold test.txt and train.txt (one
# log path per line); a fold is calibrated on its train logs and its test
# logs are scored with that site and radio map.
F=${FPBP:-target/release/fpbp}
D=${FPBP_DATASETS:-../shared/datasets}
# A variant of the folds: FOLDS_VARIANT=NAME keeps its sites, maps and
# evals in folders suffixed -NAME beside the default ones, built with the
# extra `fpbp calibrate` arguments CALIBRATE_ARGS (split on spaces), e.g.
#   FOLDS_VARIANT=wall CALIBRATE_ARGS="--radio-map-config wall.json" \
#     scripts/survey-coverage.sh build f1
VARIANT=${FOLDS_VARIANT:+-$FOLDS_VARIANT}
read -r -a CALIBRATE_EXTRA <<<"${CALIBRATE_ARGS:-}"

# The sorted logs of a shared set into the array ALL and its imported
# site.json into $site: f1, f4, ipin, f3 (ILC site1/F3) or s2f1 (site2/F1).
logs_of_set() {
    case $1 in
    f1)
        mapfile -t ALL < <(ls "$D"/ilc/site1/F1/path_data_files/*.txt.gz | sort)
        site=out/sites/ilc-site1-F1/site.json
        ;;
    f4)
        mapfile -t ALL < <(ls "$D"/ilc/site2/F4/path_data_files/*.txt.gz | sort)
        site=out/sites/ilc-site2-F4/site.json
        ;;
    ipin)
        mapfile -t ALL < <(ls "$D"/ipin2023/logs/*.txt.gz | sort)
        site=out/sites/ipin2023/site.json
        ;;
    f3)
        mapfile -t ALL < <(ls "$D"/ilc/site1/F3/path_data_files/*.txt.gz | sort)
        site=out/sites/ilc-site1-F3/site.json
        ;;
    s2f1)
        mapfile -t ALL < <(ls "$D"/ilc/site2/F1/path_data_files/*.txt.gz | sort)
        site=out/sites/ilc-site2-F1/site.json
        ;;
    *) return 2 ;;
    esac
    [ -f "$site" ] || { echo "missing $site: run the imports of docs/sites.md" >&2; exit 1; }
}

# write_split DIR: the caller's arrays test and train into DIR/test.txt
# and DIR/train.txt.
write_split() {
    printf '%s\n' "${test[@]}" >"$1/test.txt"
    printf '%s\n' "${train[@]}" >"$1/train.txt"
}

# eval_args MODE SET NAME ENGINE SEEDS [EVAL ARGS...]: the eval mode's
# arguments into name, engine, seeds and the array extra (the caller's
# $usage when one is missing or MODE is not eval).
eval_args() {
    [ "$1" = eval ] || { echo "$usage" >&2; exit 2; }
    name=${3:?$usage}
    engine=${4:?$usage}
    seeds=${5:?$usage}
    extra=("${@:6}")
}

# calibrate_fold DIR [CALIBRATE ARGS...]: site-wifi.json and radio-map.json
# of DIR from its train logs (log in DIR/calib.txt).
calibrate_fold() {
    local dir=$1
    shift
    local -a train
    mapfile -t train <"$dir/train.txt"
    "$F" calibrate --site "$site" --logs "${train[@]}" --split all --wifi "$@" "${CALIBRATE_EXTRA[@]}" \
        --out "$dir/site-wifi.json" --radio-map "$dir/radio-map.json" >"$dir/calib.txt" 2>&1 ||
        { echo "calibrate failed: $dir/calib.txt" >&2; exit 1; }
    echo "$(basename "$dir"): ${#train[@]} survey logs, $(wc -l <"$dir/test.txt") test logs"
}

# eval_fold DIR OUT ENGINE SEEDS [EVAL ARGS...]: `fpbp eval` of DIR's test
# logs with its site and radio map (none with RADIO_MAP=0) into OUT (log
# in OUT.log).
eval_fold() {
    local dir=$1 out=$2 engine=$3 seeds=$4
    shift 4
    [ -f "$dir/radio-map.json" ] || { echo "missing $dir: run build first" >&2; exit 1; }
    local -a test rm=(--radio-map "$dir/radio-map.json")
    [ "${RADIO_MAP:-1}" = 0 ] && rm=()
    mapfile -t test <"$dir/test.txt"
    "$F" eval --site "$dir/site-wifi.json" --logs "${test[@]}" --split all "${rm[@]}" \
        --engine "$engine" --seeds "$seeds" "$@" --out "$out" >"$out.log" 2>&1 || {
        # eval exits non-zero when an engine positioned nothing; its
        # points.csv (every point without a pose) still counts
        compgen -G "$out/seed-*/points.csv" >/dev/null ||
            { echo "eval failed: $out.log" >&2; exit 1; }
        echo "warning: $(basename "$out"): $(grep -m1 '^error' "$out.log")" >&2
    }
}

# odd_dir SET: the odd half of SET scored with a survey of its even half
# (the same site and map as `fpbp calibrate --split even`).
odd_dir() { echo "out/odd/$1$VARIANT"; }

# build_odd SET: odd_dir's split, site and radio map.
build_odd() {
    local dir i
    dir=$(odd_dir "$1")
    logs_of_set "$1"
    local -a test=() train=()
    for i in "${!ALL[@]}"; do
        if ((i % 2 == 0)); then train+=("${ALL[$i]}"); else test+=("${ALL[$i]}"); fi
    done
    mkdir -p "$dir"
    write_split "$dir"
    calibrate_fold "$dir"
}
