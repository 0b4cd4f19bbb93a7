#!/usr/bin/env bash
# Best effort: checks that fpbp-jni (and the core under it) compiles for the
# Android targets, so cfg(target_os = "android") code (android_logger) is at
# least type-checked. Linking needs the NDK, which is not available here.
set -uo pipefail
cd "$(dirname "$0")/.."
targets=(aarch64-linux-android armv7-linux-androideabi x86_64-linux-android)
if ! command -v rustup >/dev/null; then
  echo "skipped: Android cargo check (rustup not found)"
  exit 0
fi
if ! rustup target add "${targets[@]}" >/dev/null 2>&1; then
  echo "skipped: Android cargo check (rustup could not add ${targets[*]})"
  exit 0
fi
for t in "${targets[@]}"; do
  echo "== cargo check -p fpbp-jni --target $t"
  cargo check --release -p fpbp-jni --target "$t" || { echo "Android check FAILED for $t"; exit 1; }
done
echo "android-check: fpbp-jni type-checks for ${targets[*]}"
