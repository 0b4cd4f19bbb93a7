#!/bin/sh
# Regenerates the simulated demo-site logs shipped in host-tests/logs/:
# seeds 1-8, 120 s each, the phone in a swinging hand for seeds 3 and 6 and
# held in front otherwise (demo-walk-N / demo-swinging-N).
# Usage (from the repository root):
#   host-tests/logs/generate.sh           # writes the logs here
#   host-tests/logs/generate.sh --check   # regenerates into a temp dir and compares byte for byte
# FPBP overrides the binary (default: target/release/fpbp, built with
# `cargo build --release -p fpbp-cli`).
set -eu
FPBP=${FPBP:-target/release/fpbp}
SITE=maps/demo/site.json
OUT=host-tests/logs
if [ "${1:-}" = "--check" ]; then
    OUT=$(mktemp -d)
fi
names=""
for seed in 1 2 3 4 5 6 7 8; do
    case $seed in
        3 | 6) profile=swinging name=demo-swinging-$seed.log.gz ;;
        *) profile=default name=demo-walk-$seed.log.gz ;;
    esac
    "$FPBP" simulate --site "$SITE" --seconds 120 --seed $seed --profile $profile --out "$OUT/$name"
    names="$names $name"
done
if [ "${1:-}" = "--check" ]; then
    status=0
    for f in $names; do
        if cmp -s "$OUT/$f" "host-tests/logs/$f"; then
            echo "same: $f"
        else
            echo "DIFFERENT: $f (site, profile defaults or simulator changed: rerun without --check)"
            status=1
        fi
    done
    rm -rf "$OUT"
    exit $status
fi
