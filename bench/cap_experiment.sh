#!/usr/bin/env bash
# What the radius cap and the representative rule do to the bar: pcl_ecs at 10% and 3% of the
# bunny and the fandisk with --radius-cap 5, 3 and 2 and the target-following cap (all with the
# paper's representative rule, --rep-offset 1), then the target cap with --rep-offset 0.5 (the
# default) and 0.25, all without the gap bound (--max-gap 0 --target-gap 0); measured with
# pcl_ecs_eval. Writes bench/results/cap_experiment.md (quality only, so it can run on a busy machine).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/experiment_env.sh"
out=$here/results/cap_experiment.md
{
  echo "| input | target | radius cap | representative offset | output points | surface RMS | coverage max | edge mean |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
  for pair in bunny:bunny_mesh fandisk_scan:fandisk_mesh; do
    cloud=${pair%%:*}
    mesh=${pair##*:}
    for ratio in 0.1 0.03; do
      for run in 5:1 3:1 2:1 target:1 target:0.5 target:0.25; do
        cap=${run%%:*}
        rep=${run##*:}
        # Without the gap bound (bench/gap_experiment.sh measures that one): the cover alone.
        "$build/tools/pcd_simplify" "$data/$cloud.pcd" "$tmp/s.pcd" --target-ratio "$ratio" --rep-offset "$rep" \
          --max-gap 0 --target-gap 0 \
          $( [ "$cap" = target ] && echo "--target-cap 2.5" || echo "--radius-cap $cap --target-cap 0") -q
        "$build/tools/pcl_ecs_eval" "$data/$cloud.pcd" "$tmp/s.pcd" --mesh "$data/$mesh.ply" --json > "$tmp/e.json"
        python3 - "$cloud" "$ratio" "$cap" "$rep" "$tmp/e.json" <<'PY'
import json, sys
c, r, cap, rep, f = sys.argv[1:]
j = json.load(open(f))
print(f"| {c} | {float(r):.0%} | {cap} | {rep} | {j['simplified_points']} | {j['surface_rms']:.2e} | {j['coverage_max']:.2e} | {j['edge_mean']:.2e} |")
PY
      done
    done
  done
} > "$out"
cat "$out"
