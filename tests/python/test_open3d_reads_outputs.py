"""Open3D (its tensor API, which shows every field of a file) reads what pcd_simplify writes: every
encoding, the input's attribute names, no padding fields, and values equal to what was meant.

The input is written here by hand with numpy, independently of our writers. Each input point has a
unique intensity (and a `label` equal to its row), so every output point names the input point
whose attributes it carries: colour, normal and label must be that point's, and a feature point's
position too.

PLY: Open3D's reader skips `uint` properties (it warns), and PCL's typed readers need `label` as
`uint`, so a PLY's `label` is for PCL and CloudCompare, not Open3D; PCD carries it to all three.
"""
import subprocess

import numpy as np
import open3d as o3d
import pytest

N = 6000


def make_input(path):
    rng = np.random.default_rng(5)
    i = np.arange(N)
    z = 1.0 - 2.0 * (i + 0.5) / N
    s = np.sqrt(1.0 - z * z)
    t = np.pi * (3.0 - np.sqrt(5.0)) * i
    xyz = np.stack([s * np.cos(t), s * np.sin(t), z], axis=1)
    xyz[:, 2] = np.where(xyz[:, 2] > 0.5, 0.5, xyz[:, 2])  # a flat cap: a sharp rim of features
    xyz = xyz.astype(np.float32)
    normals = rng.normal(size=(N, 3)).astype(np.float32)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    colours = rng.integers(0, 256, size=(N, 3), dtype=np.uint32)
    rgb = (0xFF << 24) | (colours[:, 0] << 16) | (colours[:, 1] << 8) | colours[:, 2]
    intensity = rng.uniform(0, 1000, size=N).astype(np.float32)
    rec = np.zeros(N, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4"), ("normal_x", "<f4"),
                             ("normal_y", "<f4"), ("normal_z", "<f4"), ("intensity", "<f4"), ("label", "<u4")])
    rec["x"], rec["y"], rec["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    rec["rgb"] = rgb
    rec["normal_x"], rec["normal_y"], rec["normal_z"] = normals[:, 0], normals[:, 1], normals[:, 2]
    rec["intensity"] = intensity
    rec["label"] = i
    header = (
        "VERSION 0.7\nFIELDS x y z rgb normal_x normal_y normal_z intensity label\n"
        "SIZE 4 4 4 4 4 4 4 4 4\nTYPE F F F U F F F F U\nCOUNT 1 1 1 1 1 1 1 1 1\n"
        f"WIDTH {N}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {N}\nDATA binary\n"
    )
    path.write_bytes(header.encode() + rec.tobytes())
    return xyz, colours.astype(np.uint8), normals, intensity


@pytest.fixture(scope="module")
def simplified(tools, tmp_path_factory):
    d = tmp_path_factory.mktemp("o3d")
    src = d / "in.pcd"
    truth = make_input(src)
    outputs = {}
    for name, flags in [("binary.pcd", []), ("ascii.pcd", ["--ascii"]), ("compressed.pcd", ["--compressed"]),
                        ("binary.ply", []), ("ascii.ply", ["--ascii"])]:
        out = d / name
        run = subprocess.run([str(tools / "pcd_simplify"), str(src), str(out), "--labels", "--quiet", *flags],
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr
        outputs[name] = o3d.t.io.read_point_cloud(str(out))
    return truth, outputs


@pytest.mark.parametrize("name", ["binary.pcd", "ascii.pcd", "compressed.pcd", "binary.ply", "ascii.ply"])
def test_open3d_reads_every_attribute(simplified, name):
    (xyz, colours, normals, intensity), outputs = simplified
    pc = outputs[name]
    keys = set(pc.point)
    assert "_" not in keys, keys
    pcd = name.endswith(".pcd")
    ecs_key = "ecs_label" if pcd else "scalar_ecs_label"
    assert {"positions", "colors", "normals", "intensity", ecs_key} <= keys, keys
    m = pc.point.positions.shape[0]
    assert 100 < m < N
    # The source row of every output point, from its (unique) intensity.
    row_of = {float(v): k for k, v in enumerate(intensity)}
    got_intensity = pc.point.intensity.numpy().reshape(-1).astype(np.float32)
    src = np.array([row_of[float(v)] for v in got_intensity], dtype=np.int64)
    if pcd:
        np.testing.assert_array_equal(pc.point["label"].numpy().reshape(-1).astype(np.int64), src)
    # Attributes are the source point's (colours as Open3D gives them: uint8, or floats in [0, 1]).
    got_colours = pc.point.colors.numpy()
    if got_colours.dtype != np.uint8:
        got_colours = np.round(got_colours * 255.0).astype(np.uint8)
    np.testing.assert_array_equal(got_colours, colours[src])
    np.testing.assert_array_equal(pc.point.normals.numpy().astype(np.float32), normals[src])
    # Features are their input point; representatives lie near the sphere or its cap.
    labels = pc.point[ecs_key].numpy().reshape(-1)
    assert set(np.unique(labels)) <= {1, 2}
    pos = pc.point.positions.numpy().astype(np.float32)
    feat = labels == 1
    assert feat.sum() > 0, "the cap's rim should give feature points"
    np.testing.assert_array_equal(pos[feat], xyz[src[feat]])
    r = np.linalg.norm(pos.astype(np.float64), axis=1)
    on_sphere = np.abs(r - 1.0) < 0.02
    on_cap = np.abs(pos[:, 2] - 0.5) < 0.02
    assert np.all(on_sphere | on_cap)


def test_every_encoding_gives_the_same_points(simplified):
    _, outputs = simplified
    ref = outputs["binary.pcd"]
    for name, pc in outputs.items():
        np.testing.assert_array_equal(pc.point.positions.numpy(), ref.point.positions.numpy(), err_msg=name)
        np.testing.assert_array_equal(pc.point.intensity.numpy(), ref.point.intensity.numpy(), err_msg=name)
