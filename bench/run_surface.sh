#!/usr/bin/env bash
# Cocone against PCL's GreedyProjectionTriangulation and Poisson and CGAL's Advancing Front, on
# simplified shared scans and 100k-point clouds, then on the ten shared closed shapes simplified to
# 10% and 3% (the bar of docs/SURFACE.md). Release build; writes bench/results/surface.{json,md}
# and bench/results/surface_closed.{json,md}.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=${BUILD_DIR:-$root/build}
data=${PCL_ECS_SHARED_DATA_DIR:-$root/../shared/data}
if [[ ! -x $build/bench/bench_surface ]]; then
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPCL_ECS_BUILD_TOOLS=ON -DPCL_ECS_BUILD_BENCH=ON > /dev/null
  cmake --build "$build" --target bench_surface
fi
mkdir -p "$here/results"
{
  echo "# bench_surface ($(date -u +%Y-%m-%d), $(nproc) cores, $(uname -m))"
  "$build/bench/bench_surface" "$data" "$here/results/surface.json" 2>/dev/null | grep -v "^Vertex pair not in list"
} | tee "$here/results/surface.md"
{
  echo "# bench_surface --closed ($(date -u +%Y-%m-%d), $(nproc) cores, $(uname -m))"
  echo
  "$build/bench/bench_surface" "$data" "$here/results/surface_closed.json" --closed 2>/dev/null | grep -v "^Vertex pair not in list"
} | tee "$here/results/surface_closed.md"
