#!/usr/bin/env bash
# Every mode users call, timed whole-process against the peers at the same size, in one run:
# writes bench/results/modes.{json,md}, the table of docs/BENCHMARKS.md. Release build; the bucket
# farthest-point sampler (fpsample, pinned in bench/requirements-modes.txt) goes into
# bench/.venv-modes. Takes about 20 minutes on a 2-core machine.
#   bash bench/run_modes.sh [--repeat N] [--inputs A.pcd B.pcd] [--ratios 0.1 0.03]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=${BUILD_DIR:-$root/build}
data=${PCL_ECS_SHARED_DATA_DIR:-$root/../shared/data}
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPCL_ECS_BUILD_TOOLS=ON -DPCL_ECS_BUILD_BENCH=ON > /dev/null
cmake --build "$build" --target pcd_simplify pcd_make_scan bench_throughput > /dev/null
if [[ ! -x $here/.venv-modes/bin/python ]]; then
  python3 -m venv "$here/.venv-modes"
  "$here/.venv-modes/bin/pip" install --quiet -r "$here/requirements-modes.txt"
fi
cd "$root"
"$here/.venv-modes/bin/python" "$here/modes.py" --build "$build" --shared "$data" --out "$here/results" \
  --fps-python "$here/.venv-modes/bin/python" "$@"
