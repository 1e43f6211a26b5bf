#!/usr/bin/env bash
# Regenerates the issue-2 throughput figures (docs/BENCHMARKS.md): pcl_ecs vs PCL VoxelGrid and
# CGAL hierarchy_simplify_point_set at the same output size (10% of the input), Release build.
#   bash bench/run_throughput.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-bench/results}
mkdir -p "$out"
bash scripts/install_deps.sh
bash scripts/build.sh -DPCL_ECS_BUILD_TOOLS=ON -DPCL_ECS_BUILD_BENCH=ON
shared=../shared/data
echo "machine: $(nproc) cores, $(grep MemTotal /proc/meminfo | awk '{print int($2/1048576)" GiB"}')"
./build/bench/bench_throughput --mesh "$shared/bunny_mesh.ply" --points 1000000 --keep 0.10 \
  --json "$out/bunny_mesh_1M.json"
./build/bench/bench_throughput --mesh "$shared/fandisk_mesh.ply" --points 1000000 --keep 0.10 \
  --json "$out/fandisk_mesh_1M.json"
./build/bench/bench_throughput --cloud "$shared/terrain_csite1_utm.pcd" --keep 0.10 \
  --json "$out/terrain_csite1_utm.json"
