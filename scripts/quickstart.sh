#!/usr/bin/env bash
# Sets up everything on a fresh Debian machine and runs the main job on the bundled sample:
# installs the packages, builds in Release, and simplifies data/bunny.pcd with pcd_simplify.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh
mkdir -p out
set -x
./build/tools/pcd_simplify data/bunny.pcd out/bunny_simplified.pcd \
  --features out/bunny_features.pcd --stats out/bunny_stats.json
