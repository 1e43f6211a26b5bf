#!/usr/bin/env python3
"""What each rule of ours does to the result, measured: every rule switched back to the paper's
(or off), one at a time, against the defaults, on the shared scans of one half or both, at 10%,
3% and 1% kept (pcd_simplify --target-ratio). Writes bench/results/rules.md (docs/RESULTS.md
includes it): per rule and half, the median and the range over the runs of (rule off) ÷
(defaults) for each pcl_ecs_eval metric. Above 1: the rule helps that metric.

    python3 bench/rules.py [--halves checking,tuning] [--build build]
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# The halves of bench_peers.cpp (sharedInputs): file, reference mesh or None.
HALVES = {
    "tuning": [("bunny.pcd", None), ("fandisk_scan.pcd", "fandisk_mesh.ply"), ("bun000_rangescan.pcd", None),
               ("table_scene_mug_organized.pcd", None), ("terrain_csite1_utm.pcd", None),
               ("pinion_scan.pcd", "pinion_mesh.ply"), ("turbine_scan.pcd", "turbine_mesh.ply"),
               ("spot_scan.pcd", "spot_mesh.ply"), ("fertility_scan.pcd", "fertility_mesh.ply"),
               ("room_scan2.pcd", None)],
    "checking": [("joint_scan.pcd", "joint_mesh.ply"), ("spool_scan.pcd", "spool_mesh.ply"),
                 ("part_scan.pcd", "part_mesh.ply"), ("camelhead_scan.pcd", "camelhead_mesh.ply"),
                 ("elephant_scan.pcd", "elephant_mesh.ply"), ("terrain_csite2_utm.pcd", None),
                 ("kinect_capture0001.pcd", None), ("face_model.pcd", None), ("region_growing_rgb.pcd", None),
                 ("rops_points.pcd", None)],
}
# The name bench_peers.cpp (sharedInputs) gives each file: an entry's "input" in bench/results/peers.json.
NAMES = {"bunny.pcd": "bunny", "fandisk_scan.pcd": "fandisk", "bun000_rangescan.pcd": "bun000",
         "table_scene_mug_organized.pcd": "mug", "terrain_csite1_utm.pcd": "terrain", "pinion_scan.pcd": "pinion",
         "turbine_scan.pcd": "turbine", "spot_scan.pcd": "spot", "fertility_scan.pcd": "fertility",
         "room_scan2.pcd": "room", "joint_scan.pcd": "joint", "spool_scan.pcd": "spool", "part_scan.pcd": "part",
         "camelhead_scan.pcd": "camelhead", "elephant_scan.pcd": "elephant", "terrain_csite2_utm.pcd": "terrain2",
         "kinect_capture0001.pcd": "kinect", "face_model.pcd": "face", "region_growing_rgb.pcd": "region_rgb",
         "rops_points.pcd": "rops"}
# Each rule and the flags that switch it back to the paper's (or off).
RULES = [
    ("representative fit (METHOD.md 4)", ["--no-rep-fit"]),
    ("representatives relaxed to their cells' centroids (4)", ["--no-relax"]),
    ("rough balls keep their centre (4)", ["--max-roughness", "10"]),
    ("representative moves across the surface only (4)", ["--rep-cutoff", "0.001"]),
    ("representative within 0.5 r (4)", ["--rep-offset", "1"]),
    ("adaptive T_err (step 5)", ["--no-adapt"]),
]
METRICS = [("surface_rms", "surface RMS"), ("tangent_rms", "tangent RMS"), ("coverage_max", "coverage max"),
           ("mesh_mean", "output → mesh"), ("edge_mean", "sharp edges")]
RATIOS = (0.1, 0.03, 0.01)


def run(build, data, work, src, mesh, ratio, flags, size=None):
    """pcd_simplify at `ratio` kept (of the points less coincident ones), or at `size` points when given,
    scored by pcl_ecs_eval."""
    out = os.path.join(work, "out.pcd")
    target = ["--target-size", str(size)] if size else ["--target-ratio", str(ratio)]
    subprocess.run([os.path.join(build, "tools", "pcd_simplify"), os.path.join(data, src), out]
                   + target + ["--quiet"] + flags, check=True, stderr=subprocess.DEVNULL)
    cmd = [os.path.join(build, "tools", "pcl_ecs_eval"), os.path.join(data, src), out, "--json"]
    if mesh:
        cmd += ["--mesh", os.path.join(data, mesh)]
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--halves", default="checking,tuning")
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--data", default=os.environ.get("PCL_ECS_SHARED_DATA_DIR", os.path.join(ROOT, "..", "shared", "data")))
    args = ap.parse_args()
    lines = ["## What each rule does, measured", "",
             "`python3 bench/rules.py` (pcd_simplify `--target-ratio` 10%, 3% and 1% on every scan of the half, the",
             "rule switched back to the paper's or off, against the defaults): per rule, the median and the",
             "range over the runs of (rule off) ÷ (defaults). Above 1 the rule helps that metric; below 1 it",
             "costs it.", ""]
    with tempfile.TemporaryDirectory() as work:
        for half in args.halves.split(","):
            base = {}
            for src, mesh in HALVES[half]:
                for r in RATIOS:
                    base[(src, r)] = run(args.build, args.data, work, src, mesh, r, [])
            lines += [f"### The {half} half", "",
                      "| rule (flags that switch it off) | " + " | ".join(t for _, t in METRICS) + " |",
                      "|" + " --- |" * (len(METRICS) + 1)]
            for name, flags in RULES:
                ratios = {k: [] for k, _ in METRICS}
                for src, mesh in HALVES[half]:
                    for r in RATIOS:
                        q = run(args.build, args.data, work, src, mesh, r, flags)
                        for k, _ in METRICS:
                            if base[(src, r)].get(k):
                                ratios[k].append(q[k] / base[(src, r)][k])
                cells = [f"{statistics.median(v):.3f} ({min(v):.2f}-{max(v):.2f})" if v else "" for v in ratios.values()]
                lines.append(f"| {name} (`{' '.join(flags)}`) | " + " | ".join(cells) + " |")
                print(lines[-1], flush=True)
            lines.append("")
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", "rules.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
