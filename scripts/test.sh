#!/usr/bin/env bash
# The one command that runs every test of fpbp (README.md names it).
# Rust: format, lints, unit/property/integration tests (tests that need
# ../shared/datasets say so and skip when it is missing). JVM: see host-tests/.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy -D warnings"
cargo clippy --workspace --all-targets --release -- -D warnings
echo "== cargo test"
cargo test --workspace --release
if [ -x host-tests/jvm/run.sh ]; then
  echo "== JVM host tests (Kotlin bridge against the real libfpbp)"
  host-tests/jvm/run.sh
fi
