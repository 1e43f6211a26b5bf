#!/usr/bin/env bash
# The project's test command (CI runs exactly this): installs what is missing, builds in Release
# and runs every test (C++ with ctest; Python with pytest, in a venv under build/ with the pinned
# tests/python/requirements.txt and the package itself, pip install .); then the C++ tests under AddressSanitizer + UBSan; then fuzzes
# the cloud readers for a bounded time. PCL_ECS_QUICK=1 skips the sanitizer and fuzz stages.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh

echo "== Release build and tests"
bash scripts/build.sh -DPCL_ECS_BUILD_TESTS=ON -DPCL_ECS_BUILD_BENCH=ON -DPCL_ECS_BUILD_TOOLS=ON
ctest --test-dir build --output-on-failure --parallel 2

echo "== Python tests (pytest)"
venv=build/venv-tests
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check -r tests/python/requirements.txt
echo "== The Python package (pip install .)"
"$venv/bin/pip" install --quiet --disable-pip-version-check .
PCL_ECS_TOOLS="$PWD/build/tools" "$venv/bin/python" -m pytest -p no:cacheprovider -q tests/python

if [ "${PCL_ECS_QUICK:-0}" = "1" ]; then
  exit 0
fi

echo "== AddressSanitizer + UndefinedBehaviorSanitizer build and tests"
BUILD_DIR=build-asan bash scripts/build.sh -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPCL_ECS_SANITIZE=ON \
  -DPCL_ECS_BUILD_TESTS=ON -DPCL_ECS_BUILD_TOOLS=ON -DPCL_ECS_BUILD_BENCH=OFF
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure --parallel 2 -E install_consumer

echo "== Fuzzing the PCD / PLY / XYZ readers (${PCL_ECS_FUZZ_SECONDS:-60} s)"
bash scripts/fuzz.sh "${PCL_ECS_FUZZ_SECONDS:-60}"

echo "== Release tests again (the closing summary)"
ctest --test-dir build --parallel 2
