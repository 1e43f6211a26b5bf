#!/usr/bin/env python3
"""Peak memory of pcl_ecs.simplify on a large numpy array, against the array itself and against
pcd_simplify on the same points (docs/PYTHON.md, "Memory").

    python3 bench/python_memory.py [N]        (default N = 10,000,000; needs `pip install .`)

A scan of N points is made with pcd_make_scan (bunny mesh, 8 range scans) as a binary PCD and
loaded into an (N, 3) array with numpy alone. Each case runs in a fresh process: the array is
made, the process's peak resident size is reset (/proc/self/clear_refs), then simplify runs with
--terr 1e-3 on 2 threads; the figure is the peak minus the resident size just before the call,
so the array itself is not counted. pcd_simplify's figure is its whole-process peak (GNU time)
minus its size at start-up (a run on 100 points).
"""
import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
TOOLS = ROOT / "build" / "tools"
MESH = ROOT.parent / "shared" / "data" / "bunny_mesh.ply"

CHILD = r'''
import json, sys, numpy as np, pcl_ecs
path, dtype = sys.argv[1], sys.argv[2]
data = open(path, "rb").read()
start = data.index(b"DATA binary\n") + len(b"DATA binary\n")
rec = np.frombuffer(data, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("i", "<f4"), ("s", "u1")], offset=start)
points = np.stack([rec["x"], rec["y"], rec["z"]], axis=1).astype(dtype)
del rec, data
def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) * 1024
open("/proc/self/clear_refs", "w").write("5")
before = status("VmRSS:")
r = pcl_ecs.simplify(points, error_threshold=1e-3, threads=2)
print(json.dumps({"array_bytes": points.nbytes, "before": before, "peak": status("VmHWM:"),
                  "output_points": len(r.points)}))
'''


def peak_tool(args):
    t = subprocess.run(["/usr/bin/time", "-v", str(TOOLS / "pcd_simplify"), *args], capture_output=True, text=True)
    if t.returncode != 0:
        sys.exit(t.stderr)
    return int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t.stderr).group(1)) * 1024


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000_000
    mib = 1 << 20
    with tempfile.TemporaryDirectory() as d:
        d = pathlib.Path(d)
        scan = d / "scan.pcd"
        subprocess.run([str(TOOLS / "pcd_make_scan"), str(MESH), str(scan), "--points", str(n), "--scans", "8",
                        "--quiet"], check=True)
        small = d / "small.pcd"
        subprocess.run([str(TOOLS / "pcd_make_scan"), str(MESH), str(small), "--points", "100", "--quiet"], check=True)
        rows = []
        for dtype in ("float32", "float64"):
            out = subprocess.run([sys.executable, "-c", CHILD, str(scan), dtype], capture_output=True, text=True)
            if out.returncode != 0:
                sys.exit(out.stderr)
            j = json.loads(out.stdout)
            extra = j["peak"] - j["before"]
            rows.append(f"| `pcl_ecs.simplify`, {dtype} array | {j['array_bytes'] / mib:.0f} | {extra / mib:.0f} | "
                        f"{extra / j['array_bytes']:.2f} | {extra / n:.0f} |")
        base = peak_tool([str(small), str(d / "o.pcd"), "--quiet"])
        peak = peak_tool([str(scan), str(d / "o.pcd"), "--terr", "1e-3", "--threads", "2", "--quiet"])
        extra = peak - base
        rows.append(f"| `pcd_simplify` (PCD file, float32 x y z + 2 fields) | - | {extra / mib:.0f} | - | "
                    f"{extra / n:.0f} |")
    print(f"Peak memory above the process's size before the call, {n:,} points, --terr 1e-3, 2 threads "
          f"(`python3 bench/python_memory.py {n}`):\n")
    print("| run | input array MiB | peak above it MiB | × the array | bytes a point |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(r)


if __name__ == "__main__":
    main()
