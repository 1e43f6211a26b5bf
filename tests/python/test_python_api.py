"""The Python package pcl_ecs (pip install .): the same output as pcd_simplify, every parameter
a keyword with the library's validation, float32 and float64 inputs, the readers and writers, and
the examples of docs/PYTHON.md (LAZ with laspy, Open3D) run as tests.
"""
import json
import pathlib
import subprocess

import laspy
import numpy as np
import open3d as o3d
import pytest

import pcl_ecs

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data"


def fibonacci_sphere(n, dtype=np.float64):
    i = np.arange(n)
    z = 1.0 - 2.0 * (i + 0.5) / n
    s = np.sqrt(1.0 - z * z)
    t = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([s * np.cos(t), s * np.sin(t), z], axis=1).astype(dtype)


def sphere_with_cap(n=6000, dtype=np.float64):
    pts = fibonacci_sphere(n, dtype)
    pts[:, 2] = np.minimum(pts[:, 2], 0.5)
    return pts


def test_simplify_equals_pcd_simplify_on_the_bunny(tools, tmp_path):
    bunny = SHARED / "bunny.pcd"
    fields = pcl_ecs.read(bunny)
    points = np.stack([fields["x"], fields["y"], fields["z"]], axis=1)
    assert points.dtype == np.float32
    for args, kwargs in (([], {}), (["--target-ratio", "0.05"], {"target_ratio": 0.05}),
                         (["--terr", "0.002", "--alpha", "4"], {"error_threshold": 0.002, "feature_factor": 4})):
        out = tmp_path / "out.pcd"
        stats = tmp_path / "s.json"
        r = subprocess.run([str(tools / "pcd_simplify"), str(bunny), str(out), "--quiet", "--labels", "--stats",
                            str(stats), *args], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        res = pcl_ecs.simplify(points, **kwargs)
        cli = pcl_ecs.read(out)
        cli_points = np.stack([cli["x"], cli["y"], cli["z"]], axis=1).astype(np.float64)
        assert np.array_equal(res.points, cli_points), args
        assert np.array_equal(res.labels, cli["ecs_label"]), args
        s = json.loads(stats.read_text())
        assert res.summary["counts"] == s["counts"]
        assert res.summary["parameters"] == s["parameters"]
        # Attributes travel through source_index, as pcd_simplify carries them.
        assert np.array_equal(points[res.source_index][res.labels == 1], cli_points[res.labels == 1])


def test_result_arrays_describe_the_run():
    pts = sphere_with_cap()
    r = pcl_ecs.simplify(pts)
    m = len(r.points)
    assert r.points.shape == (m, 3) and r.points.dtype == np.float64
    assert r.labels.dtype == np.uint8 and set(np.unique(r.labels)) <= {1, 2}
    assert r.source_index.dtype == np.int64 and r.source_index.shape == (m,)
    assert r.input_to_output.shape == (len(pts),) and r.input_to_output.min() >= 0
    feats = r.labels == 1
    assert feats.sum() == r.summary["counts"]["feature_points"] > 0
    assert np.array_equal(r.points[feats], pts[r.source_index[feats]])  # features are input points
    assert len(r.balls) == r.summary["counts"]["balls"]
    assert (r.balls["radius"] >= 0).all() and (r.balls["error"] <= r.balls["tolerance"] + 1e-15).all()
    assert r.balls["replaced"].sum() + feats.sum() >= len(pts) - r.summary["counts"]["merged_points"]


def test_float32_and_float64_give_the_same_cloud():
    # The same coordinates as float32 and as float64: the same run; the output is stored in the
    # input's type, so the float32 run's points are the float64 run's rounded to float32.
    a = pcl_ecs.simplify(sphere_with_cap(dtype=np.float32))
    b = pcl_ecs.simplify(sphere_with_cap(dtype=np.float32).astype(np.float64))
    assert np.array_equal(a.labels, b.labels) and np.array_equal(a.source_index, b.source_index)
    assert np.array_equal(a.points, b.points.astype(np.float32).astype(np.float64))
    assert not np.array_equal(a.points, b.points), "float64 keeps the representatives' precision"


def test_every_parameter_is_a_keyword_that_round_trips():
    defaults = pcl_ecs.Parameters()
    names = pcl_ecs.parameter_names()
    assert "error_threshold" in names and "target_size" in names and len(names) == 23
    changed = {"error_threshold": 0.002, "error_threshold_abs": 0.05, "feature_factor": 5.0, "k_neighbors": 12, "error_form": "paper",
               "adaptive": False, "adaptive_factor": 3.0, "radius_cap_factor": 4.0, "target_radius_cap": 2.0,
               "max_representative_offset": 0.7, "representative_cutoff": 0.1, "max_roughness": 0.3, "representative_fit": False,
               "relax_representatives": False, "feature_spacing": 1.5,
               "max_gap_factor": 0.8, "target_gap_factor": 0.5, "seed": 7, "threads": 1,
               "use_input_normals": False, "target_size": 0, "max_deviation": 0.05,
               "report_deviation": True}
    assert set(changed) == set(names)
    r = pcl_ecs.simplify(sphere_with_cap(), **changed)
    # The summary spells every parameter as pcd_simplify's flag (one table for both).
    spelling = {row["field"]: row["name"] for row in pcl_ecs._core._parameter_table()}
    assert set(spelling) == set(names)
    for name, value in changed.items():
        # The switches --no-adapt, --no-rep-fit and --no-relax say the opposite of their fields.
        expected = (not value) if name in ("adaptive", "representative_fit", "relax_representatives") else value
        assert r.summary["parameters"][spelling[name]] == expected, name
    assert getattr(defaults, "error_threshold") == 1e-3 and defaults.k_neighbors == 16


@pytest.mark.parametrize("kwargs,message", [
    ({"error_threshold": 0.0}, "error_threshold"),
    ({"error_threshold": 2.0}, "error_threshold"),
    ({"k_neighbors": 2}, "k_neighbors"),
    ({"error_form": "cubic"}, "error_form"),
    ({"feature_factor": -1.0}, "feature_factor"),
    ({"target_ratio": 1.5}, "target_ratio"),
    ({"use_input_normals": True}, "normals"),
])
def test_bad_values_raise_value_error_with_the_library_message(kwargs, message):
    with pytest.raises(ValueError, match=message):
        pcl_ecs.simplify(sphere_with_cap(), **kwargs)


def test_unknown_keywords_and_bad_arrays_are_refused():
    with pytest.raises(TypeError, match="unexpected keyword"):
        pcl_ecs.simplify(sphere_with_cap(), terr=0.01)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        pcl_ecs.simplify(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="colors"):
        pcl_ecs.simplify(sphere_with_cap(), colors=np.zeros((5, 3), np.uint8))
    with pytest.raises(ValueError):
        pcl_ecs.simplify(np.zeros((5, 3)))  # fewer points than K + 1


def test_an_error_is_the_exception_alone(capfd):
    # The library's message comes back in the exception, and nothing is printed besides it.
    capfd.readouterr()
    with pytest.raises(ValueError, match="identical"):
        pcl_ecs.simplify(np.ones((100, 3)))
    with pytest.raises(ValueError, match="no finite points"):
        pcl_ecs.simplify(np.full((100, 3), np.nan))
    out, err = capfd.readouterr()
    assert out == "" and err == "", err


def test_nan_rows_are_dropped_as_in_cpp():
    pts = sphere_with_cap()
    clean = pcl_ecs.simplify(pts)
    holed = pts.copy()
    holed[::7] = np.nan
    r = pcl_ecs.simplify(holed)
    assert r.summary["counts"]["finite_points"] == len(pts) - len(pts[::7])
    assert (r.input_to_output[::7] == -1).all()
    assert np.isfinite(r.points).all()
    assert clean.summary["counts"]["finite_points"] == len(pts)


def test_read_write_round_trip(tmp_path):
    pts = sphere_with_cap()
    colors = (np.arange(len(pts) * 3) % 256).astype(np.uint8).reshape(-1, 3)
    for name in ("c.pcd", "c.ply", "c.las") + (("c.laz",) if pcl_ecs.laz_supported else ()):
        pcl_ecs.write(tmp_path / name, pts, colors=colors)
        back = pcl_ecs.read(tmp_path / name)
        xyz = np.stack([back["x"], back["y"], back["z"]], axis=1)
        tol = 0.0 if name.endswith((".pcd", ".ply")) else 1e-6
        assert np.abs(xyz - pts).max() <= tol, name
    with pytest.raises(ValueError, match="no such file|truncated|not a LAS"):
        (tmp_path / "bad.las").write_bytes(b"LASF" + bytes(100))
        pcl_ecs.read(tmp_path / "bad.las")


def test_write_keeps_any_named_field(tmp_path):
    pts = sphere_with_cap(2000)
    n = len(pts)
    rng = np.random.default_rng(5)
    fields = {
        "classification": rng.integers(0, 32, n).astype(np.uint8),
        "gps_time": rng.uniform(0, 1e6, n),
        "point_source_id": rng.integers(0, 65536, n).astype(np.uint16),
        "label": rng.integers(-2**31, 2**31, n).astype(np.int32),
        "big": rng.integers(0, 2**63, n, dtype=np.uint64),
        "descriptor": rng.standard_normal((n, 5)).astype(np.float32),
        "flag": rng.integers(0, 2, n).astype(bool),
    }
    for name in ("f.pcd", "f.ply"):
        pcl_ecs.write(tmp_path / name, pts, fields=fields)
        back = pcl_ecs.read(tmp_path / name)
        for k, v in fields.items():
            if v.ndim == 2 and name.endswith(".ply"):  # PLY: one property per column, NAME_i
                got = np.stack([back[f"{k}_{c}"] for c in range(v.shape[1])], axis=1)
            else:
                got = back[k]
            if name.endswith(".ply") and k == "big":
                assert np.array_equal(got, v.astype(np.float64)), "PLY has no 64-bit integers: a double"
                continue
            assert np.array_equal(got, v.astype(np.uint8) if v.dtype == bool else v), (name, k)
    # LAS: the LAS dimensions by name (format 1: GPS time), the others as extra dimensions (an
    # (N, count) array a column each), checked by laspy; read gives them back by name.
    pcl_ecs.write(tmp_path / "f.las", pts, fields=fields)
    las = laspy.read(tmp_path / "f.las")
    assert las.header.point_format.id == 1
    assert np.array_equal(np.asarray(las.classification), fields["classification"])
    assert np.array_equal(np.asarray(las.gps_time), fields["gps_time"])
    assert np.array_equal(np.asarray(las.point_source_id), fields["point_source_id"])
    columns = [f"descriptor_{c}" for c in range(5)]
    assert list(las.point_format.extra_dimension_names) == ["label", "big"] + columns + ["flag"]
    back = pcl_ecs.read(tmp_path / "f.las")
    for k in ("label", "big", "flag"):
        want = fields[k].astype(np.uint8) if k == "flag" else fields[k]
        assert np.asarray(las[k]).dtype == want.dtype, k
        assert np.array_equal(np.asarray(las[k]), want), k
        assert np.array_equal(back[k], want), k
    for c, name in enumerate(columns):
        assert np.array_equal(np.asarray(las[name]), fields["descriptor"][:, c]), name
    with pytest.raises(ValueError, match="1 to 31 characters"):
        pcl_ecs.write(tmp_path / "long.las", pts, fields={"n" * 32: np.zeros(n)})
    assert not (tmp_path / "long.las").exists()
    # Bad fields: what is wrong, and no file.
    for bad, match in [({"x": pts[:, 0]}, "given twice"), ({"c": np.zeros(n + 1)}, "N the number of points"),
                       ({"c": np.array(["a"] * n)}, "integers or floats"), ({"a b": np.zeros(n)}, "without spaces")]:
        with pytest.raises(ValueError, match=match):
            pcl_ecs.write(tmp_path / "bad.pcd", pts, fields=bad)
        assert not (tmp_path / "bad.pcd").exists()


def test_reconstruct_closes_a_sphere():
    pts = fibonacci_sphere(3000)
    v, tri = pcl_ecs.reconstruct(pts)
    assert v.shape == pts.shape and tri.dtype == np.int64
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all(), "closed and manifold: every edge has two triangles"
    assert len(np.unique(tri)) - len(counts) + len(tri) == 2  # Euler characteristic of a sphere


def test_point_radius_is_each_output_points_ball():
    fields = pcl_ecs.read(SHARED / "bunny.pcd")
    points = np.stack([fields["x"], fields["y"], fields["z"]], axis=1)
    res = pcl_ecs.simplify(points, target_ratio=0.1)
    r = res.point_radius
    assert r.shape == (len(res.points),) and r.dtype == np.float64
    assert (r[res.labels == 1] == 0).all(), "a feature point stands for no ball"
    # Each ball stands behind exactly one output point: the radii are the balls' radii, one each.
    assert np.array_equal(np.sort(r[res.labels == 2]), np.sort(res.balls["radius"]))


def test_reconstruct_refuses_triangles_between_balls_that_do_not_overlap():
    # A sphere whose northern cap (z > 0.5) carries radii of a tenth of the spacing, the rest none
    # (NaN: unknown): no Cocone triangle may join two cap points (2 x the sum of their radii is far
    # below any edge), so the cap has no triangle of its own; without radii it is meshed like the
    # rest, and the triangles among points of unknown radius are the same.
    pts = fibonacci_sphere(3000)
    radius = np.where(pts[:, 2] > 0.5, 0.1 * np.sqrt(4 * np.pi / 3000), np.nan)
    _, tri = pcl_ecs.reconstruct(pts, radius=radius)
    _, tri0 = pcl_ecs.reconstruct(pts)
    assert ((radius[tri] > 0).sum(axis=1) < 2).all(), "a triangle with an edge between two cap points"
    assert (radius[tri0] > 0).all(axis=1).sum() > 500
    unknown = np.isnan(radius)
    assert unknown[tri].all(axis=1).sum() == unknown[tri0].all(axis=1).sum()
    # A radius of 0 marks a point kept as it is: it takes its nearest ball's radius, so the points
    # of radius 0 along the cap's rim are not joined to one another as the unknown ones are.
    rim = np.where(pts[:, 2] > 0.5, radius, 0.0)
    _, tri_rim = pcl_ecs.reconstruct(pts, radius=rim)
    assert (rim[tri_rim] == 0).all(axis=1).sum() < unknown[tri].all(axis=1).sum()
    with pytest.raises(ValueError, match="N the number of points"):
        pcl_ecs.reconstruct(pts, radius=radius[:-1])


def test_reconstruct_opens_the_turbines_bolt_holes_against_its_scan():
    # The turbine simplified to 10%: its ten bolt holes, one point spacing across, come out capped
    # on both faces of the flange (Euler characteristic 0: the bore alone); with the scan they are
    # opened (-20, genus 11), with the filter's own scan-to-point map or the nearest point.
    scan_path = SHARED / "turbine_scan.pcd"
    if not scan_path.exists():
        pytest.skip("shared data missing")
    fields = pcl_ecs.read(scan_path)
    scan = np.stack([fields["x"], fields["y"], fields["z"]], axis=1).astype(np.float64)
    res = pcl_ecs.simplify(scan, target_ratio=0.1)

    def euler(v, tri):
        edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
        return len(np.unique(tri)) - len(np.unique(edges, axis=0)) + len(tri)

    v, tri = pcl_ecs.reconstruct(res.points, radius=res.point_radius)
    assert euler(v, tri) == 0
    v, tri = pcl_ecs.reconstruct(res.points, radius=res.point_radius, scan=scan,
                                 scan_to_point=res.input_to_output)
    assert euler(v, tri) == -20
    v, tri = pcl_ecs.reconstruct(res.points, radius=res.point_radius, scan=scan)
    assert euler(v, tri) == -20
    with pytest.raises(ValueError, match="M the number of scan points"):
        pcl_ecs.reconstruct(res.points, scan=scan, scan_to_point=res.input_to_output[:-1])
    with pytest.raises(ValueError, match="scan_to_point is read with scan only"):
        pcl_ecs.reconstruct(res.points, scan_to_point=res.input_to_output)


# ---- the examples of docs/PYTHON.md --------------------------------------------------------------

def test_example_laz_to_laz_with_laspy_keeps_every_dimension(tmp_path):
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.array([0.01, 0.01, 0.01])
    header.offsets = np.array([500000.0, 4100000.0, 0.0])
    las = laspy.LasData(header)
    pts = sphere_with_cap() * 10.0
    las.x, las.y, las.z = pts[:, 0] + 500000.0, pts[:, 1] + 4100000.0, pts[:, 2]
    rng = np.random.default_rng(3)
    las.intensity = rng.permutation(len(pts)).astype(np.uint16)
    las.classification = rng.integers(0, 32, len(pts)).astype(np.uint8)
    las.gps_time = rng.uniform(0, 1e5, len(pts))
    las.red = rng.integers(0, 65536, len(pts)).astype(np.uint16)
    src_path = tmp_path / "in.las"
    las.write(src_path)

    # The example: read with laspy, simplify the coordinates, keep every dimension by source_index.
    las = laspy.read(src_path)
    r = pcl_ecs.simplify(np.stack([las.x, las.y, las.z], axis=1), target_ratio=0.1)
    out = laspy.LasData(las.header)
    out.points = las.points[r.source_index]
    out.x, out.y, out.z = r.points[:, 0], r.points[:, 1], r.points[:, 2]
    out.write(tmp_path / "out.laz")

    back = laspy.read(tmp_path / "out.laz")
    assert len(back.points) == len(r.points)
    for dim in ("intensity", "classification", "gps_time", "red"):
        assert np.array_equal(np.asarray(back[dim]), np.asarray(las[dim])[r.source_index]), dim
    assert np.abs(np.asarray(back.x) - r.points[:, 0]).max() <= 0.005 + 1e-9


def test_example_open3d_point_cloud_round_trip():
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(sphere_with_cap()))
    pcd.colors = o3d.utility.Vector3dVector(np.random.default_rng(1).uniform(0, 1, (6000, 3)))

    r = pcl_ecs.simplify(np.asarray(pcd.points), target_ratio=0.1)
    small = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(r.points))
    small.colors = o3d.utility.Vector3dVector(np.asarray(pcd.colors)[r.source_index])

    assert len(small.points) == len(r.points)
    assert abs(len(r.points) - 600) <= 60
    assert np.array_equal(np.asarray(small.colors), np.asarray(pcd.colors)[r.source_index])


def test_max_deviation_holds_and_is_reported():
    # In the input's units and as a percentage of L: every input point within the bound of the
    # output's surface, measured by the library and reported in the summary; checked here against
    # an independent measure (numpy: the plane of each point's 8 nearest output points).
    pts = sphere_with_cap()
    plain = pcl_ecs.simplify(pts, report_deviation=True)
    dev = plain.summary["deviation"]
    assert dev is not None and dev["max"] > 0 and dev["bound"] == 0
    bound = 0.25 * dev["max"]
    for value in (bound, f"{100 * bound / plain.summary['geometry']['bbox_diagonal']!r}%"):
        r = pcl_ecs.simplify(pts, max_deviation=value)
        d = r.summary["deviation"]
        assert d["max"] <= bound * (1 + 1e-9) and d["added_points"] > 0
        assert len(r.points) > len(plain.points)
        # Independent check with numpy.
        out = r.points
        worst = 0.0
        for q in pts[::7]:
            d2 = ((out - q) ** 2).sum(axis=1)
            near = np.argsort(d2)[:8]
            c = out[near].mean(axis=0)
            n = np.linalg.eigh(np.cov((out[near] - c).T, bias=True))[1][:, 0]
            worst = max(worst, min(abs((q - c) @ n), float(np.sqrt(d2.min()))))
        assert worst <= bound + 1e-6  # float coordinates in the library's local frame
    assert pcl_ecs.simplify(pts).summary["deviation"] is None
    with pytest.raises(ValueError, match="target_size"):
        pcl_ecs.simplify(pts, max_deviation=bound, target_size=100)
    with pytest.raises(ValueError, match="max_deviation"):
        pcl_ecs.simplify(pts, max_deviation="abc")


def test_the_type_stubs_name_every_parameter_with_the_library_default():
    import ast
    stub = ast.parse((pathlib.Path(pcl_ecs.__file__).with_suffix(".pyi")).read_text())
    fn = next(n for n in stub.body if isinstance(n, ast.FunctionDef) and n.name == "simplify")
    defaults = {a.arg: ast.literal_eval(d) for a, d in zip(fn.args.kwonlyargs, fn.args.kw_defaults)}
    p = pcl_ecs.Parameters()
    for name in pcl_ecs.parameter_names():
        assert name in defaults, name
        assert defaults[name] == getattr(p, name), name
