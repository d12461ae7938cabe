#!/usr/bin/env bash
# Installs dependencies, builds relume twice (release, and ASan+UBSan) and runs every test in
# both builds. This is the README's test command and exactly what CI runs.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
start=$(date +%s)

echo "== release build"
bash scripts/build.sh release
ctest --test-dir build/release --output-on-failure -j "$(nproc)" --timeout 900

echo "== AddressSanitizer + UndefinedBehaviorSanitizer build"
bash scripts/build.sh asan
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp:print_suppressions=0" \
  ctest --test-dir build/asan --output-on-failure -j "$(nproc)" --timeout 1800 -LE benchmark

echo "== all tests passed in $(( $(date +%s) - start )) s"
