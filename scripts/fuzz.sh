#!/usr/bin/env bash
# Builds relume's fuzz harnesses with clang + libFuzzer (coverage-guided) and AddressSanitizer +
# UBSan into build/fuzz, then fuzzes each for SECONDS (default 300) with its seeds from
# fuzz/corpus/<harness>/. New inputs go to build/fuzz/corpus/<harness>/, findings (crash-*,
# timeout-*, oom-*) to build/fuzz/artifacts/. The CTest runs (fuzz.*) use relume's own mutation
# driver instead (fuzz/driver.cc); this is for long runs (docs/ci.md lists them).
#   scripts/fuzz.sh [SECONDS] [HARNESS ...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-300}"
shift || true
harnesses=("$@")
if [ ${#harnesses[@]} -eq 0 ]; then
  harnesses=(rig_yaml scene_yaml mesh json sun_csv frame_file session_db)
fi
bash scripts/install-deps.sh --fuzz
cmake -S . -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1" -DRELUME_SANITIZE=ON \
  -DRELUME_LIBFUZZER=ON -DRELUME_BUILD_BENCHMARKS=OFF -DRELUME_PCH=OFF >/dev/null
targets=()
for h in "${harnesses[@]}"; do targets+=("${h}_fuzzer"); done
cmake --build build/fuzz -j "$(nproc)" --target "${targets[@]}"
mkdir -p build/fuzz/artifacts
for h in "${harnesses[@]}"; do
  mkdir -p "build/fuzz/corpus/$h"
  echo "== $h: ${seconds} s"
  # -rss_limit_mb: a decoder asked for a huge image is refused by relume (or OpenCV) before it
  # allocates; more than 2 GB is a finding.
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
    "build/fuzz/fuzz/${h}_fuzzer" "build/fuzz/corpus/$h" "fuzz/corpus/$h" -max_total_time="$seconds" \
    -rss_limit_mb=2048 -timeout=10 -artifact_prefix="build/fuzz/artifacts/${h}-" -print_final_stats=1 2>&1 |
    grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss_mb|==[0-9]+==ERROR|SUMMARY|artifact_prefix|Test unit written)" || true
done
ls build/fuzz/artifacts
