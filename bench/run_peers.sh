#!/usr/bin/env bash
# The judge in one command: build (Release), install the Python samplers and plotting into
# bench/.venv (bench/requirements.txt), run bench_peers on every shared scan at 10%, 3% and 1% kept
# against every peer, a sweep of sizes on the bunny and the fandisk for the plots, then
# docs/RESULTS.md and its plots (bench/make_results.py); with RULES=1 also bench/rules.py.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=${BUILD_DIR:-$root/build}
data=${PCL_ECS_SHARED_DATA_DIR:-$root/../shared/data}
work=${PEERS_WORKDIR:-/tmp/pcl_ecs_peers}
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPCL_ECS_BUILD_TOOLS=ON -DPCL_ECS_BUILD_BENCH=ON > /dev/null
cmake --build "$build" --target bench_peers > /dev/null
if [[ ! -x $here/.venv/bin/python ]]; then
  python3 -m venv "$here/.venv"
fi
"$here/.venv/bin/pip" install --quiet -r "$here/requirements.txt"
py=(--python "$here/.venv/bin/python" --py-peers "$here/py_peers.py")
mkdir -p "$here/results" "$work"
"$build/bench/bench_peers" --data "$data" --out "$here/results/peers_sweep.json" --workdir "$work/sweep" "${py[@]}" \
  --inputs bunny,fandisk --ratios 0.2,0.05,0.02,0.01 2>/dev/null > "$work/peers_sweep.md"
"$build/bench/bench_peers" --data "$data" --out "$here/results/peers.json" --workdir "$work" "${py[@]}" \
  --ratios 0.1,0.03,0.01 2>/dev/null | tee "$work/peers.md"
# What each of our rules does (bench/results/rules.md, in docs/RESULTS.md): RULES=1 to rerun it.
if [[ ${RULES:-0} == 1 ]]; then
  cmake --build "$build" --target pcd_simplify pcl_ecs_eval > /dev/null
  "$here/.venv/bin/python" "$here/rules.py" --build "$build" --data "$data"
fi
"$here/.venv/bin/python" "$here/make_results.py" "$work"
