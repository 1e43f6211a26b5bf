#!/usr/bin/env bash
# Builds the libFuzzer target over the cloud readers with clang and runs it for $1 seconds
# (default 60) from the seed corpus in tests/fuzz/corpus. A crash exits non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DPCL_ECS_FUZZ=ON \
  -DPCL_ECS_BUILD_TESTS=OFF -DPCL_ECS_BUILD_TOOLS=OFF -DPCL_ECS_BUILD_BENCH=OFF >/dev/null
cmake --build build-fuzz --parallel 2 --target fuzz_cloud_readers
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp tests/fuzz/corpus/* "$work/"
mkdir -p build-fuzz/artifacts
./build-fuzz/tests/fuzz/fuzz_cloud_readers -max_total_time="$seconds" -rss_limit_mb=2048 \
  -max_len=65536 -artifact_prefix=build-fuzz/artifacts/ -print_final_stats=1 "$work" 2>&1 | tail -n 15
