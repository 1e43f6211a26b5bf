#!/usr/bin/env bash
# Sets up what the tools need on a fresh Debian machine and runs the main job on the bundled
# sample: installs the packages (scripts/install_deps.sh --tools), builds pcd_simplify alone in
# Release (the tests and benchmarks are configured off; scripts/test.sh turns them back on), and
# simplifies data/bunny.pcd.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh --tools
BUILD_TARGETS=pcd_simplify bash scripts/build.sh -DPCL_ECS_BUILD_TESTS=OFF -DPCL_ECS_BUILD_BENCH=OFF
mkdir -p out
set -x
./build/tools/pcd_simplify data/bunny.pcd out/bunny_simplified.pcd \
  --features out/bunny_features.pcd --stats out/bunny_stats.json
