"""Open3D (its tensor API, which shows every field of a file) reads what pcd_simplify writes: for
the fields of every point type the filter supports and every encoding, the input's attribute names,
no padding field, and values equal to what was meant.

The inputs are written here by hand with numpy, independently of our writers. Every input point has
a unique position and unique attribute values, so each output point's attributes must be exactly
those of one input point (its source), and a feature point's position must be that point's too.

PLY: Open3D's reader skips `uint` properties (it warns), and PCL's typed readers need `label` as
`uint`, so a PLY's `label` is for PCL and CloudCompare, not Open3D; PCD carries it to all three.
"""
import subprocess

import numpy as np
import open3d as o3d
import pytest

N = 6000

# The fields of each point type the filter supports (PCL's names; rgba is PointXYZRGBA's).
POINT_TYPES = {
    "PointXYZ": [],
    "PointXYZI": ["intensity"],
    "PointXYZL": ["label"],
    "PointXYZRGB": ["rgb"],
    "PointXYZRGBA": ["rgba"],
    "PointXYZRGBL": ["rgb", "label"],
    "PointNormal": ["normals"],
    "PointXYZRGBNormal": ["rgb", "normals"],
    "PointXYZINormal": ["intensity", "normals"],
}
ENCODINGS = {"binary.pcd": [], "ascii.pcd": ["--ascii"], "compressed.pcd": ["--compressed"],
             "binary.ply": [], "ascii.ply": ["--ascii"]}


def make_input(path, attributes):
    """A sphere with a flat cap (a sharp rim of feature points) and random attributes."""
    rng = np.random.default_rng(5)
    i = np.arange(N)
    z = 1.0 - 2.0 * (i + 0.5) / N
    s = np.sqrt(1.0 - z * z)
    t = np.pi * (3.0 - np.sqrt(5.0)) * i
    xyz = np.stack([s * np.cos(t), s * np.sin(t), np.minimum(z, 0.5)], axis=1).astype(np.float32)
    fields = [("x", "<f4", "F"), ("y", "<f4", "F"), ("z", "<f4", "F")]
    values = {"x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2]}
    if "rgb" in attributes or "rgba" in attributes:
        name = "rgba" if "rgba" in attributes else "rgb"
        colours = rng.integers(0, 256, size=(N, 4), dtype=np.uint32)
        alpha = colours[:, 3] if name == "rgba" else np.full(N, 255, np.uint32)
        values[name] = (alpha << 24) | (colours[:, 0] << 16) | (colours[:, 1] << 8) | colours[:, 2]
        fields.append((name, "<u4", "U"))
    if "normals" in attributes:
        n = rng.normal(size=(N, 3)).astype(np.float32)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        for k, a in enumerate("xyz"):
            values["normal_" + a] = n[:, k]
            fields.append(("normal_" + a, "<f4", "F"))
    if "intensity" in attributes:
        values["intensity"] = rng.permutation(N).astype(np.float32) * 0.25
        fields.append(("intensity", "<f4", "F"))
    if "label" in attributes:
        values["label"] = rng.permutation(N).astype(np.uint32)
        fields.append(("label", "<u4", "U"))
    rec = np.zeros(N, dtype=[(f, d) for f, d, _ in fields])
    for f, _, _ in fields:
        rec[f] = values[f]
    header = (
        "VERSION 0.7\nFIELDS " + " ".join(f for f, _, _ in fields) + "\nSIZE " + " ".join("4" for _ in fields) +
        "\nTYPE " + " ".join(t for _, _, t in fields) + "\nCOUNT " + " ".join("1" for _ in fields) +
        f"\nWIDTH {N}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {N}\nDATA binary\n"
    )
    path.write_bytes(header.encode() + rec.tobytes())
    return values


def open3d_columns(pc, attributes, ply):
    """The per-point values Open3D gives, under our field names (colours as bytes r, g, b[, a])."""
    cols = {}
    if "rgb" in attributes or "rgba" in attributes:
        c = pc.point.colors.numpy()
        if c.dtype != np.uint8:
            c = np.round(c * 255.0).astype(np.uint8)
        cols["colour"] = c[:, :3]
    if "normals" in attributes:
        n = pc.point.normals.numpy().astype(np.float32)
        cols["normal_x"], cols["normal_y"], cols["normal_z"] = n[:, 0], n[:, 1], n[:, 2]
    if "intensity" in attributes:
        cols["intensity"] = pc.point.intensity.numpy().reshape(-1).astype(np.float32)
    if "label" in attributes and not ply:
        cols["label"] = pc.point.label.numpy().reshape(-1).astype(np.uint32)
    return cols


def input_columns(values, attributes):
    cols = {}
    for name in ("rgb", "rgba"):
        if name in values:
            v = values[name]
            cols["colour"] = np.stack([(v >> 16) & 0xFF, (v >> 8) & 0xFF, v & 0xFF], axis=1).astype(np.uint8)
    for name in ("normal_x", "normal_y", "normal_z", "intensity", "label"):
        if name in values:
            cols[name] = values[name]
    return cols


@pytest.mark.parametrize("point_type", list(POINT_TYPES))
def test_open3d_reads_every_encoding(tools, tmp_path, point_type):
    attributes = POINT_TYPES[point_type]
    values = make_input(tmp_path / "in.pcd", attributes)
    xyz = np.stack([values["x"], values["y"], values["z"]], axis=1)
    row_of = {tuple(p): k for k, p in enumerate(xyz.tolist())}
    want = input_columns(values, attributes)
    reference = None
    for name, flags in ENCODINGS.items():
        out = tmp_path / name
        run = subprocess.run([str(tools / "pcd_simplify"), str(tmp_path / "in.pcd"), str(out), "--labels", "--quiet",
                              *flags], capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr
        pc = o3d.t.io.read_point_cloud(str(out))
        keys = set(pc.point)
        ply = name.endswith(".ply")
        assert "_" not in keys, (name, keys)
        ecs_key = "scalar_ecs_label" if ply else "ecs_label"
        assert ecs_key in keys, (name, keys)
        pos = pc.point.positions.numpy().astype(np.float32)
        m = pos.shape[0]
        assert 100 < m < N, name
        got = open3d_columns(pc, attributes, ply)
        assert set(got) == set(want) - ({"label"} if ply else set()), (name, keys)
        labels = pc.point[ecs_key].numpy().reshape(-1)
        assert set(np.unique(labels)) <= {1, 2}, name
        feat = labels == 1
        assert feat.sum() > 0, "the cap's rim gives feature points"
        # A feature is its input point: position and every attribute.
        src = np.array([row_of.get(tuple(p), -1) for p in pos[feat].tolist()])
        assert np.all(src >= 0), f"{name}: a feature point is not an input point"
        for col, v in got.items():
            np.testing.assert_array_equal(v[feat], want[col][src], err_msg=f"{name} {col}")
        # Every point's attributes are, together, those of one input point.
        if got:
            rows = {tuple(np.concatenate([np.atleast_1d(want[c][k]).astype(np.float64) for c in sorted(want)
                                          if c in got]).tolist()) for k in range(N)}
            for k in range(m):
                key = tuple(np.concatenate([np.atleast_1d(got[c][k]).astype(np.float64) for c in sorted(got)]).tolist())
                assert key in rows, f"{name}: point {k}'s attributes are no input point's"
        # Representatives lie on the sphere or its cap.
        r = np.linalg.norm(pos.astype(np.float64), axis=1)
        assert np.all((np.abs(r - 1.0) < 0.02) | (np.abs(pos[:, 2] - 0.5) < 0.02)), name
        # Every encoding holds the same points.
        if reference is None:
            reference = pos
        else:
            np.testing.assert_array_equal(pos, reference, err_msg=name)
