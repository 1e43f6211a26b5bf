#!/usr/bin/env python3
"""Times every mode a user calls pcd_simplify in, whole process, against the peers at the same
output size, in one run (docs/BENCHMARKS.md). Run through bench/run_modes.sh.

For each input and kept ratio:
  pcd_simplify --target-ratio R             what users ask first ("give me N points")
  pcd_simplify --target-size N              the same size given as a count
  pcd_simplify --terr T --radius-cap C --max-gap G --feature-spacing F
                                            the plain run at the settings the target run settled
                                            on: the same output, one cover (less the points a
                                            top-up added: counts.size_points, at most 2%)
  pcd_simplify --stream (the same flags but F: every feature point kept)
                                            out of core
  PCL VoxelGrid, CGAL hierarchy_simplify_point_set   calibrated to the target run's size
                                            (bench_throughput --peers-only: the algorithm's time
                                            in a process of its own, input already loaded)
  bucket farthest-point sampling (fpsample) the same size; the sampling call, input loaded
Every time is the least of --repeat runs (pcl_ecs's four modes run in turn in each round). pcl_ecs
times are whole processes (reading the file and writing the result included); the peers' are their
algorithm alone, which favours them.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def least_walls(cmds, repeat):
    """The least wall time of each command over `repeat` rounds, each round running every command
    once in turn: the machine's drift from minute to minute reaches every mode alike, so the
    ratios between them hold better than those of back-to-back repeats."""
    best = [None] * len(cmds)
    for _ in range(repeat):
        for i, cmd in enumerate(cmds):
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            dt = time.perf_counter() - t0
            best[i] = dt if best[i] is None else min(best[i], dt)
    return best


def pcd_points(path):
    """The x y z of a binary PCD written by bench_throughput --save-input, as an (N, 3) float32 array."""
    import numpy as np
    with open(path, "rb") as f:
        header = {}
        while True:
            line = f.readline().decode("ascii").strip()
            if not line or line.startswith("#"):
                continue
            key, *values = line.split()
            header[key] = values
            if key == "DATA":
                break
        if header["DATA"][0] != "binary":
            raise SystemExit(path + ": expected binary PCD")
        names, sizes, types, counts = header["FIELDS"], header["SIZE"], header["TYPE"], header.get("COUNT")
        counts = counts or ["1"] * len(names)
        fields = []
        for i, (n, s, t, c) in enumerate(zip(names, sizes, types, counts)):
            kind = {"F": "f", "I": "i", "U": "u"}[t]
            fields.append(((n if n != "_" else "_pad%d" % i), "<%s%s" % (kind, s), (int(c),) if int(c) > 1 else ()))
        dt = np.dtype([(n, t, shape) if shape else (n, t) for n, t, shape in fields])
        count = int(header["POINTS"][0])
        data = np.frombuffer(f.read(count * dt.itemsize), dtype=dt, count=count)
    xyz = np.stack([data["x"], data["y"], data["z"]], axis=1).astype(np.float32)
    return xyz[np.isfinite(xyz).all(axis=1)]


FPS_CHILD = r"""
import sys, time, numpy as np, fpsample
p = np.load(sys.argv[1]); n = int(sys.argv[2])
t0 = time.perf_counter(); idx = fpsample.bucket_fps_kdline_sampling(p, n, h=7); dt = time.perf_counter() - t0
print(len(idx), dt)
"""


def fps_time(python, npy, n, repeat):
    best = None
    size = 0
    for _ in range(repeat):
        out = subprocess.run([python, "-c", FPS_CHILD, npy, str(n)], check=True, capture_output=True, text=True)
        size, dt = out.stdout.split()
        best = float(dt) if best is None else min(best, float(dt))
    return int(size), best


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--shared", default="../shared/data")
    ap.add_argument("--out", default="bench/results")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--fps-python", default="", help="a Python with numpy and fpsample (bench/.venv)")
    ap.add_argument("--inputs", nargs="*", default=None, help="PCD files (default: the set below)")
    ap.add_argument("--ratios", nargs="*", type=float, default=[0.1, 0.03])
    args = ap.parse_args()

    tools = os.path.join(args.build, "tools")
    simplify = os.path.join(tools, "pcd_simplify")
    peers = os.path.join(args.build, "bench", "bench_throughput")
    work = tempfile.mkdtemp(prefix="ecs_modes_")
    inputs = args.inputs
    if not inputs:
        scan = os.path.join(work, "bunny_scan_1M.pcd")
        subprocess.run([os.path.join(tools, "pcd_make_scan"), os.path.join(args.shared, "bunny_mesh.ply"), scan,
                        "--points", "1000000", "--quiet"], check=True)
        inputs = [scan] + [os.path.join(args.shared, f) for f in (
            "fandisk_scan.pcd", "pinion_scan.pcd", "elephant_scan.pcd", "room_scan2.pcd",
            "terrain_csite2_utm.pcd", "terrain_csite1_utm.pcd")]
    rows = []
    for path in inputs:
        name = os.path.basename(path)
        plain_input = os.path.join(work, "input.pcd")
        subprocess.run([peers, "--cloud", path, "--save-input", plain_input], check=True)
        npy = os.path.join(work, "input.npy")
        if args.fps_python:
            import numpy as np
            np.save(npy, pcd_points(plain_input))
        for ratio in args.ratios:
            out = os.path.join(work, "out.pcd")
            stats = os.path.join(work, "stats.json")
            subprocess.run([simplify, path, out, "--target-ratio", str(ratio), "--stats", stats, "-q"], check=True)
            st = json.load(open(stats))
            p, c = st["parameters"], st["counts"]
            size, target = c["output_points"], st["target"]["size"]
            plain = ["--terr", repr(p["terr-used"]), "--radius-cap", repr(p["radius-cap-used"]),
                     "--max-gap", repr(p["max-gap-used"])]
            # The feature thinning the target chose: in the plain run, not out of core (--stream
            # keeps every feature point, so its output is larger where the target thinned them).
            thinning = ["--feature-spacing", repr(p["feature-spacing-used"])] if p.get("feature-spacing-used") else []
            row = {"input": name, "points": c["finite_points"], "ratio": ratio, "target": target, "size": size,
                   "cover_passes": c["cover_passes"], "estimated_trials": c.get("estimated_trials", 0),
                   "target_iterations": c["target_iterations"],
                   "size_points": c.get("size_points", 0)}
            stream_out = os.path.join(work, "stream.pcd")
            (row["target_ratio_s"], row["target_size_s"], row["terr_s"], row["stream_s"]) = least_walls([
                [simplify, path, out, "--target-ratio", str(ratio), "-q"],
                [simplify, path, out, "--target-size", str(target), "-q"],
                [simplify, path, out] + plain + thinning + ["-q"],
                [simplify, path, stream_out, "--stream"] + plain + ["-q"]], args.repeat)
            peer_json = os.path.join(work, "peers.json")
            subprocess.run([peers, "--cloud", plain_input, "--size", str(size), "--peers-only", "--repeat",
                            str(args.repeat), "--json", peer_json], check=True, stdout=subprocess.DEVNULL)
            pj = json.load(open(peer_json))
            row["voxel_grid"] = {"size": pj["voxel_grid"]["size"], "s": pj["voxel_grid"]["seconds"]}
            if "cgal_hierarchy" in pj:
                row["cgal_hierarchy"] = {"size": pj["cgal_hierarchy"]["size"], "s": pj["cgal_hierarchy"]["seconds"]}
            if args.fps_python:
                fsize, fs = fps_time(args.fps_python, npy, size, args.repeat)
                row["bucket_fps"] = {"size": fsize, "s": fs}
            rows.append(row)
            print(json.dumps(row), flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "modes.json"), "w") as f:
        json.dump({"repeat": args.repeat, "threads": os.cpu_count(), "rows": rows}, f, indent=2)
    with open(os.path.join(args.out, "modes.md"), "w") as f:
        f.write(table(rows))
    print(table(rows))


def table(rows):
    lines = ["| input | points | kept | size | `--target-ratio` s | `--target-size` s | `--terr` (same output) s | "
             "`--stream` s | target / terr | M points/s (target) | VoxelGrid s | CGAL hierarchy s | bucket FPS s | "
             "target / CGAL |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        cgal = r.get("cgal_hierarchy", {}).get("s")
        fps = r.get("bucket_fps", {}).get("s")
        lines.append("| %s | %d | %d%% | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.3f | %s | %s | %s |" % (
            r["input"], r["points"], round(100 * r["ratio"]), r["size"], r["target_ratio_s"], r["target_size_s"],
            r["terr_s"], r["stream_s"], r["target_ratio_s"] / r["terr_s"], r["points"] / r["target_ratio_s"] / 1e6,
            r["voxel_grid"]["s"], "%.2f" % cgal if cgal else "-", "%.2f" % fps if fps else "-",
            "%.2f" % (r["target_ratio_s"] / cgal) if cgal else "-"))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
