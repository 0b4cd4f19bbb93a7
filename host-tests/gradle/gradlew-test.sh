#!/usr/bin/env bash
# Offline checks of android/gradlew (the POSIX wrapper script) and of the
# wrapper properties; run by scripts/test.sh, a few seconds, no network.
#
# What each check guards:
# 1. android/gradle/wrapper/gradle-wrapper.properties is a real file (a
#    symlink breaks on Windows) and gradle-wrapper/gradle-wrapper.properties
#    (the repository's top-level copy) is identical to it.
# 2. Without the wrapper jar, gradlew puts the distribution where the
#    wrapper jar does (<name>/<base 36 MD5 of the URL>): the committed URL
#    gives bpt9gzteqjrbo1mjrsomdt32c, the folder name Gradle's own wrapper
#    uses for gradle-8.11.1-bin (seen in many public ~/.gradle paths), and a
#    test URL gives what python3 computes the way the jar does.
# 3. With a fake distribution zip behind a file:// URL in a temporary copy of
#    the project: the first run copies, verifies (SHA-256), unpacks and runs
#    its bin/gradle with the arguments and the caller's directory, exit code
#    passed through; the second run works with the zip gone (no download);
#    a wrong distributionSha256Sum fails before anything is unpacked; no
#    checksum property still runs (with a note); without unzip on PATH the
#    JDK's jar unpacks; two first runs at once both run and install once.
# 4. With a gradle/wrapper/gradle-wrapper.jar present, gradlew runs the jar's
#    org.gradle.wrapper.GradleWrapperMain (a stand-in compiled here) with the
#    arguments, as Gradle's own script does (skipped without javac).
set -euo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
props="$repo/android/gradle/wrapper/gradle-wrapper.properties"
shell=sh
command -v dash >/dev/null && shell=dash

fail() {
  echo "gradlew-test FAILED: $*" >&2
  exit 1
}

# 1. real file, identical copies
[ -f "$props" ] && [ ! -L "$props" ] || fail "$props is missing or a symlink"
cmp -s "$props" "$repo/gradle-wrapper/gradle-wrapper.properties" ||
  fail "gradle-wrapper/gradle-wrapper.properties differs from $props (copy it over)"
grep -q '^distributionUrl=' "$props" || fail "no distributionUrl in $props"

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# A copy of the project's wrapper files, with PROPS as its properties.
make_project() { # DIR
  mkdir -p "$1/gradle/wrapper"
  cp "$repo/android/gradlew" "$1/gradlew"
  cp "$props" "$1/gradle/wrapper/gradle-wrapper.properties"
}
set_prop() { # DIR KEY VALUE (VALUE empty: remove the key)
  local f="$1/gradle/wrapper/gradle-wrapper.properties"
  grep -v "^$2=" "$f" >"$f.new" || true
  [ -z "$3" ] || printf '%s=%s\n' "$2" "$3" >>"$f.new"
  mv "$f.new" "$f"
}

# 2. distribution folder naming
p="$tmp/naming"
make_project "$p"
got="$(FPBP_GRADLEW_PRINT_DIST_DIR=1 GRADLE_USER_HOME="$tmp/guh" "$shell" "$p/gradlew")"
url="$(sed -n 's/^distributionUrl=//p' "$props" | sed 's/\\:/:/g')"
case "$url" in
*/gradle-8.11.1-bin.zip)
  [ "$got" = "$tmp/guh/wrapper/dists/gradle-8.11.1-bin/bpt9gzteqjrbo1mjrsomdt32c" ] ||
    fail "distribution folder of $url: $got, expected .../gradle-8.11.1-bin/bpt9gzteqjrbo1mjrsomdt32c"
  ;;
*) echo "note: distributionUrl is no longer 8.11.1; the known-folder check is skipped" ;;
esac
if command -v python3 >/dev/null; then
  test_url="file:///tmp/some where/gradle-9.9-test-bin.zip"
  set_prop "$p" distributionUrl "$(printf '%s' "$test_url" | sed 's/:/\\:/g')"
  want="$(python3 -c '
import hashlib, sys
n = int(hashlib.md5(sys.argv[1].encode()).hexdigest(), 16)
d = "0123456789abcdefghijklmnopqrstuvwxyz"; s = ""
while n: s = d[n % 36] + s; n //= 36
print(s or "0")' "$test_url")"
  got="$(FPBP_GRADLEW_PRINT_DIST_DIR=1 GRADLE_USER_HOME="$tmp/guh" "$shell" "$p/gradlew")"
  [ "$got" = "$tmp/guh/wrapper/dists/gradle-9.9-test-bin/$want" ] ||
    fail "distribution folder of $test_url: $got, expected .../gradle-9.9-test-bin/$want"
fi

# 3. a fake distribution behind a file:// URL
dist_src="$tmp/src/gradle-9.9-fake"
mkdir -p "$dist_src/bin"
cat >"$dist_src/bin/gradle" <<'EOF'
#!/bin/sh
echo "FAKE GRADLE in $(pwd -P): $*"
[ "${1:-}" = fail ] && exit 7
exit 0
EOF
chmod +x "$dist_src/bin/gradle"
zip="$tmp/gradle-9.9-fake-bin.zip"
if command -v zip >/dev/null; then
  (cd "$tmp/src" && zip -q -r "$zip" gradle-9.9-fake)
elif command -v jar >/dev/null; then
  (cd "$tmp/src" && jar cfM "$zip" gradle-9.9-fake)
else
  (cd "$tmp/src" && python3 -m zipfile -c "$zip" gradle-9.9-fake)
fi
sha="$(sha256sum "$zip" 2>/dev/null | cut -d' ' -f1 || shasum -a 256 "$zip" | cut -d' ' -f1)"

p="$tmp/project"
make_project "$p"
set_prop "$p" distributionUrl "file\\://$zip"
set_prop "$p" distributionSha256Sum "$sha"
guh="$tmp/guh3"
mkdir -p "$tmp/caller"
out="$(cd "$tmp/caller" && GRADLE_USER_HOME="$guh" "$shell" "$p/gradlew" tasks --offline 2>"$tmp/err")" ||
  fail "first run: exit $?: $(cat "$tmp/err")"
[ "$out" = "FAKE GRADLE in $(cd "$tmp/caller" && pwd -P): tasks --offline" ] || fail "first run printed: $out"
dist_dir="$(FPBP_GRADLEW_PRINT_DIST_DIR=1 GRADLE_USER_HOME="$guh" "$shell" "$p/gradlew")"
[ -x "$dist_dir/gradle-9.9-fake/bin/gradle" ] || fail "not unpacked into $dist_dir"
[ -f "$dist_dir/gradle-9.9-fake-bin.zip.ok" ] || fail "no .ok marker in $dist_dir"
[ "$(find "$dist_dir" -mindepth 1 -maxdepth 1 -type d | wc -l)" -eq 1 ] ||
  fail "$dist_dir must hold exactly one folder (the wrapper jar requires it)"

status=0
(cd "$tmp/caller" && GRADLE_USER_HOME="$guh" "$shell" "$p/gradlew" fail >/dev/null 2>&1) || status=$?
[ "$status" -eq 7 ] || fail "exit code of bin/gradle not passed through: $status"

mv "$zip" "$zip.away"
out="$(GRADLE_USER_HOME="$guh" "$shell" "$p/gradlew" again 2>&1)" || fail "second run (zip gone): $out"
case "$out" in *"FAKE GRADLE in "*": again") ;; *) fail "second run printed: $out" ;; esac
case "$out" in *Downloading*) fail "second run downloaded again" ;; esac
mv "$zip.away" "$zip"

# Two first runs at once (an IDE and a terminal): both run, one install.
guh2="$tmp/guh-par"
(GRADLE_USER_HOME="$guh2" "$shell" "$p/gradlew" one >"$tmp/par1" 2>&1) &
pid1=$!
(GRADLE_USER_HOME="$guh2" "$shell" "$p/gradlew" two >"$tmp/par2" 2>&1) &
pid2=$!
wait "$pid1" || fail "parallel run 1: $(cat "$tmp/par1")"
wait "$pid2" || fail "parallel run 2: $(cat "$tmp/par2")"
grep -q "FAKE GRADLE in .*: one" "$tmp/par1" || fail "parallel run 1 printed: $(cat "$tmp/par1")"
grep -q "FAKE GRADLE in .*: two" "$tmp/par2" || fail "parallel run 2 printed: $(cat "$tmp/par2")"
par_dir="$(FPBP_GRADLEW_PRINT_DIST_DIR=1 GRADLE_USER_HOME="$guh2" "$shell" "$p/gradlew")"
[ "$(find "$par_dir" -mindepth 1 -maxdepth 1 -type d | wc -l)" -eq 1 ] || fail "parallel runs left $(ls "$par_dir")"
[ -z "$(find "$guh2" -name '*gradlew-lock*')" ] || fail "parallel runs left a lock"

bad="$tmp/bad"
make_project "$bad"
set_prop "$bad" distributionUrl "file\\://$zip"
set_prop "$bad" distributionSha256Sum "0000000000000000000000000000000000000000000000000000000000000000"
status=0
out="$(GRADLE_USER_HOME="$tmp/guh-bad" "$shell" "$bad/gradlew" tasks 2>&1)" || status=$?
[ "$status" -ne 0 ] || fail "a wrong distributionSha256Sum was accepted: $out"
case "$out" in *"Verification of Gradle distribution failed"*) ;; *) fail "wrong checksum message: $out" ;; esac
case "$out" in *"FAKE GRADLE"*) fail "ran the distribution despite the wrong checksum" ;; esac
if find "$tmp/guh-bad" -name bin -o -name '*.ok' | grep -q .; then fail "unpacked despite the wrong checksum"; fi

nosum="$tmp/nosum"
make_project "$nosum"
set_prop "$nosum" distributionUrl "file\\://$zip"
set_prop "$nosum" distributionSha256Sum ""
out="$(GRADLE_USER_HOME="$tmp/guh-nosum" "$shell" "$nosum/gradlew" x 2>&1)" || fail "run without checksum: $out"
case "$out" in *"not verified"*"FAKE GRADLE in "*": x") ;; *) fail "run without checksum printed: $out" ;; esac

if command -v jar >/dev/null; then
  # PATH without unzip: the JDK's jar unpacks.
  tools="$tmp/tools"
  mkdir -p "$tools"
  for t in sh dash sed tr tail cut md5sum sha256sum cp mv rm mkdir chmod cat ls jar java pwd dirname; do
    if c="$(command -v "$t")"; then ln -s "$c" "$tools/$t"; fi
  done
  out="$(PATH="$tools" GRADLE_USER_HOME="$tmp/guh-jar" "$shell" "$p/gradlew" viajar 2>&1)" ||
    fail "run with jar instead of unzip: $out"
  case "$out" in *"FAKE GRADLE in "*": viajar") ;; *) fail "run with jar instead of unzip printed: $out" ;; esac
fi

# 4. with a wrapper jar: the standard behaviour
if command -v javac >/dev/null && command -v jar >/dev/null && command -v java >/dev/null; then
  src="$tmp/jar/src/org/gradle/wrapper"
  mkdir -p "$src" "$tmp/jar/classes"
  cat >"$src/GradleWrapperMain.java" <<'EOF'
package org.gradle.wrapper;

public class GradleWrapperMain {
    public static void main(String[] args) {
        System.out.println("FAKE WRAPPER JAR " + System.getProperty("org.gradle.appname") + ": " + String.join(" ", args));
    }
}
EOF
  javac -d "$tmp/jar/classes" "$src/GradleWrapperMain.java"
  jar cf "$p/gradle/wrapper/gradle-wrapper.jar" -C "$tmp/jar/classes" .
  out="$("$shell" "$p/gradlew" build --info 2>&1)" || fail "run with the wrapper jar: $out"
  [ "$out" = "FAKE WRAPPER JAR gradlew: build --info" ] || fail "run with the wrapper jar printed: $out"
else
  echo "note: javac/jar/java not found: the wrapper-jar branch of gradlew is not checked"
fi

echo "gradlew-test: ok (wrapper properties identical; gradlew without the jar: folder naming, file:// download, SHA-256 check, cached rerun, exit code, parallel first runs, jar unpack; with a jar: runs it)"
