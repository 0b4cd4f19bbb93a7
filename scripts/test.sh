#!/usr/bin/env bash
# The one command that runs every test of fpbp (README.md names it).
# Rust: format, lints, unit/property/integration tests (tests that need
# ../shared/datasets skip when it is missing). JVM: see host-tests/.
# The summary at the end lists every group of tests that was skipped and
# why; with CI=true a skipped dataset or JVM group fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."

skipped=()
datasets=../shared/datasets
if [ ! -d "$datasets/ilc" ] || [ ! -d "$datasets/ipin2023" ]; then
  files=$(grep -rl "skipped: ../shared/datasets" rust --include=*.rs | sort | tr '\n' ' ')
  n=$(grep -rh "skipped: ../shared/datasets" rust --include=*.rs | wc -l)
  skipped+=("dataset tests: $datasets (ilc/, ipin2023/) not found; $n tests pass without checking anything, in: $files")
fi
jvm=1
if ! command -v mvn >/dev/null || ! command -v java >/dev/null; then
  jvm=0
  skipped+=("JVM host tests (Kotlin bridge against libfpbp): mvn or java not on PATH")
fi

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy -D warnings"
cargo clippy --workspace --all-targets --release -- -D warnings
echo "== cargo clippy -p fpbp-jni --features self-test -D warnings (the test hooks of the host JNI library)"
cargo clippy -p fpbp-jni --all-targets --release --features self-test -- -D warnings
echo "== cargo test"
cargo test --workspace --release
echo "== scripts: shell syntax, the tuning protocol's table"
for f in scripts/*.sh scripts/lib/*.sh; do bash -n "$f"; done
python3 -m unittest discover -s scripts/lib -p 'test_*.py'
echo "== android/gradlew without and with a wrapper jar (offline, fake distribution)"
bash host-tests/gradle/gradlew-test.sh
if [ "$jvm" = 1 ] && [ -x host-tests/jvm/run.sh ]; then
  echo "== JVM host tests (Kotlin bridge against the real libfpbp)"
  host-tests/jvm/run.sh
fi

echo "== summary"
if [ ${#skipped[@]} -eq 0 ]; then
  echo "skipped groups: none (dataset tests and JVM host tests ran)"
else
  echo "skipped groups: ${#skipped[@]}"
  for s in "${skipped[@]}"; do echo "  - $s"; done
  if [ "${CI:-}" = true ]; then
    echo "CI=true: the dataset and JVM tests must run in CI; failing" >&2
    exit 1
  fi
fi
