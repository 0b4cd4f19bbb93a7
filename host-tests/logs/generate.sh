#!/bin/sh
# Regenerates the simulated demo-site logs shipped in host-tests/logs/.
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
"$FPBP" simulate --site "$SITE" --seconds 120 --seed 1 --profile default  --out "$OUT/demo-walk-1.log.gz"
"$FPBP" simulate --site "$SITE" --seconds 120 --seed 2 --profile default  --out "$OUT/demo-walk-2.log.gz"
"$FPBP" simulate --site "$SITE" --seconds 120 --seed 3 --profile swinging --out "$OUT/demo-swinging-3.log.gz"
if [ "${1:-}" = "--check" ]; then
    status=0
    for f in demo-walk-1.log.gz demo-walk-2.log.gz demo-swinging-3.log.gz; do
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
