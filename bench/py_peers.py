#!/usr/bin/env python3
"""The Python samplers users reach for, run for bench_peers in a process of their own.

    py_peers.py METHOD INPUT.f32 TARGET OUTPUT.pcd

INPUT.f32 holds the input's points as raw little-endian float32 x y z triples (bench_peers writes
it). METHOD is one of:
  meshlab_poisson   pymeshlab generate_sampling_poisson_disk(samplenum=TARGET, subsample=True,
                    exactnumflag=True): MeshLab's Poisson-disk subsampling with an exact count
  pcu_poisson       point-cloud-utils downsample_point_cloud_poisson_disk with target_num_samples
                    TARGET, random seed 1, size tolerance 1%
  fpsample_bucket   fpsample bucket_fps_kdline_sampling (bucket farthest-point sampling, QuickFPS)
                    from point 0
Every method keeps input points; OUTPUT.pcd (binary, float x y z) holds them. Prints, like
bench_peers' own children, "SIZE SECONDS PEAK_EXTRA_MIB": the time of the call alone and the peak
resident memory above what the loaded input already used.
"""
import sys
import time

import numpy as np


def status_mib(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) / 1024.0
    return 0.0


def meshlab_poisson(v, target):
    import pymeshlab
    # Centred in float64: MeshLab's own arithmetic then loses nothing on UTM-sized coordinates.
    origin = v.mean(axis=0)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v - origin))
    ms.generate_sampling_poisson_disk(samplenum=int(target), subsample=True, exactnumflag=True)
    return ms.current_mesh().vertex_matrix() + origin


def pcu_poisson(v, target):
    import point_cloud_utils as pcu
    origin = v.mean(axis=0)
    idx = pcu.downsample_point_cloud_poisson_disk(v - origin, -1.0, target_num_samples=int(target), random_seed=1,
                                                  sample_num_tolerance=0.01)
    return v[idx]


def fpsample_bucket(v, target):
    import fpsample
    h = 7 if len(v) < 400000 else 9  # the package's advice: 5-7 for medium inputs, 9 for large ones
    idx = fpsample.bucket_fps_kdline_sampling(v - v.mean(axis=0), int(target), h=h, start_idx=0)
    return v[idx]


METHODS = {"meshlab_poisson": meshlab_poisson, "pcu_poisson": pcu_poisson, "fpsample_bucket": fpsample_bucket}


def write_pcd(path, pts):
    pts = np.ascontiguousarray(pts, dtype="<f4")
    n = len(pts)
    header = (f"# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
              f"COUNT 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n")
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(pts.tobytes())


def main():
    if len(sys.argv) != 5 or sys.argv[1] not in METHODS:
        sys.stderr.write(__doc__)
        return 2
    method, src, target, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    v = np.fromfile(src, dtype="<f4").reshape(-1, 3).astype(np.float64)
    run = METHODS[method]
    __import__({"meshlab_poisson": "pymeshlab", "pcu_poisson": "point_cloud_utils",
                "fpsample_bucket": "fpsample"}[method])  # imported before the clock starts
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # VmHWM := VmRSS
    base = status_mib("VmRSS:")
    t0 = time.perf_counter()
    pts = run(v, target)
    seconds = time.perf_counter() - t0
    peak = status_mib("VmHWM:") - base
    write_pcd(out, pts)
    print(f"{len(pts)} {seconds:.9f} {peak:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
