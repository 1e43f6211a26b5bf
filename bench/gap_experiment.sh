#!/usr/bin/env bash
# What the gap bound (--max-gap, stages/gap_fill.h) does to the bar: pcl_ecs at 10% and 3% of every
# shared scan with --target-gap 0 (the paper's cover), 0.8, 0.6 (the default) and 0.4, measured with
# pcl_ecs_eval. Writes bench/results/gap_experiment.md (quality only, so it can run on a busy machine).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/experiment_env.sh"
out=$here/results/gap_experiment.md
{
  echo "| input | target | --target-gap | output points | gap points | surface RMS | coverage max | coverage mean | edge mean |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  for pair in bunny:bunny_mesh fandisk_scan:fandisk_mesh bun000_rangescan: table_scene_mug_organized: terrain_csite1_utm:; do
    cloud=${pair%%:*}
    mesh=${pair##*:}
    for ratio in 0.1 0.03; do
      for gap in 0 0.8 0.6 0.4; do
        "$build/tools/pcd_simplify" "$data/$cloud.pcd" "$tmp/s.pcd" --target-ratio "$ratio" --target-gap "$gap" \
          --stats "$tmp/s.json" -q
        "$build/tools/pcl_ecs_eval" "$data/$cloud.pcd" "$tmp/s.pcd" ${mesh:+--mesh "$data/$mesh.ply"} --json > "$tmp/e.json"
        python3 - "$cloud" "$ratio" "$gap" "$tmp/s.json" "$tmp/e.json" <<'PY'
import json, sys
c, r, gap, sf, ef = sys.argv[1:]
s, j = json.load(open(sf)), json.load(open(ef))
edge = f"{j['edge_mean']:.2e}" if j.get("edge_mean") is not None else "-"
print(f"| {c} | {float(r):.0%} | {gap} | {j['simplified_points']} | {s['counts']['gap_points']} | {j['surface_rms']:.2e} | "
      f"{j['coverage_max']:.2e} | {j['coverage_mean']:.2e} | {edge} |")
PY
      done
    done
  done
} > "$out"
cat "$out"
