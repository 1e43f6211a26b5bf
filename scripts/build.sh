#!/usr/bin/env bash
# Configures and builds pcl_ecs in Release into build/ (or $BUILD_DIR); extra arguments go to
# cmake's configure step. BUILD_TARGETS="a b" builds only those targets (and what they need).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
targets=()
for t in ${BUILD_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build_dir" --parallel 2 "${targets[@]}"
