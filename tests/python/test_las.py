"""LAS and LAZ through pcd_simplify, checked with laspy (and lazrs for LAZ) as the independent
reader and writer.

Every input is written here by laspy, for each LAS version and each point format it allows, with
random values in every dimension; `intensity` is a permutation, so it names each point's source.
Each output point must then carry every dimension of its source exactly (a feature point its x y z
too), the header must keep the input's version, point format, scale, offset and CRS VLR, and a
malformed file must be refused with exit 3 and nothing written.
"""
import json
import subprocess

import laspy
import laspy.vlrs.vlrlist
import numpy as np
import pcl_ecs
import pytest

N = 6000
SCALE = np.array([0.01, 0.01, 0.01])  # centimetre UTM
OFFSET = np.array([500000.0, 4100000.0, 200.0])
WKT = b'PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84"],UNIT["metre",1]]\x00'
FORMATS = {"1.2": range(0, 4), "1.3": range(0, 6), "1.4": range(0, 11)}
CASES = [(v, f) for v, fs in FORMATS.items() for f in fs]


def place_on_sphere(las, cap=1.0):
    """x y z of the N points: a 10 m Fibonacci sphere about OFFSET, cut flat at z = 10 cap."""
    i = np.arange(N)
    z = 1.0 - 2.0 * (i + 0.5) / N
    s = np.sqrt(1.0 - z * z)
    t = np.pi * (3.0 - np.sqrt(5.0)) * i
    las.x = OFFSET[0] + 10.0 * s * np.cos(t)
    las.y = OFFSET[1] + 10.0 * s * np.sin(t)
    las.z = OFFSET[2] + 10.0 * np.minimum(z, cap)


def make_input(path, version, fmt, extra=False):
    """A 10 m sphere with a flat cap (its rim is a sharp edge) and random values in every dimension."""
    rng = np.random.default_rng(fmt + 20 * len(version))
    header = laspy.LasHeader(point_format=fmt, version=version)
    if extra:
        header.add_extra_dim(laspy.ExtraBytesParams(name="reflectance", type=np.float32))
    header.scales = SCALE
    header.offsets = OFFSET
    header.vlrs.append(laspy.VLR(user_id="LASF_Projection", record_id=2112, description="OGC WKT",
                                 record_data=WKT))
    las = laspy.LasData(header)
    if version == "1.4":
        las.evlrs = laspy.vlrs.vlrlist.VLRList([laspy.VLR(user_id="pcl_ecs_test", record_id=7, description="an EVLR",
                                           record_data=bytes(range(256)) * 300)])
    place_on_sphere(las, cap=0.5)
    for d in las.point_format.dimensions:
        if d.name in ("X", "Y", "Z"):
            continue
        if d.name == "intensity":
            las[d.name] = rng.permutation(N).astype(np.uint16)
        elif d.kind == laspy.DimensionKind.FloatingPoint:
            las[d.name] = rng.uniform(-1e3, 1e3, N).astype(d.dtype)
        elif d.kind == laspy.DimensionKind.BitField:
            las[d.name] = rng.integers(0, 1 << d.num_bits, N).astype(np.uint8)
        else:
            info = np.iinfo(d.dtype)
            las[d.name] = rng.integers(info.min, info.max, N, endpoint=True, dtype=d.dtype)
    las.write(path)
    return laspy.read(path)


def dims(las):
    return [d for d in las.point_format.dimension_names if d not in ("X", "Y", "Z")]


def check_output(inp, out, stats):
    assert out.header.version == inp.header.version
    assert out.header.point_format.id == inp.header.point_format.id
    assert np.array_equal(out.header.scales, inp.header.scales)
    assert np.array_equal(out.header.offsets, inp.header.offsets)
    crs = [v for v in out.header.vlrs if v.user_id == "LASF_Projection"]
    assert len(crs) == 1 and crs[0].record_data_bytes() == WKT
    if inp.header.version == "1.4":
        assert [(e.user_id, e.record_id, e.record_data_bytes()) for e in out.evlrs] == \
               [(e.user_id, e.record_id, e.record_data_bytes()) for e in inp.evlrs] != []
    assert list(out.point_format.dimension_names) == list(inp.point_format.dimension_names)
    m = len(out.points)
    assert m == stats["counts"]["output_points"] and 0 < m < N
    source = np.full(65536, -1, np.int64)
    source[np.asarray(inp.intensity)] = np.arange(N)
    src = source[np.asarray(out.intensity)]
    assert (src >= 0).all(), "every output point's values are those of one input point"
    for d in dims(inp):  # bit for bit (random floats include NaNs)
        assert np.asarray(out[d]).tobytes() == np.asarray(inp[d])[src].tobytes(), d
    same = ((np.asarray(out.X) == np.asarray(inp.X)[src]) & (np.asarray(out.Y) == np.asarray(inp.Y)[src]) &
            (np.asarray(out.Z) == np.asarray(inp.Z)[src]))
    assert same.sum() >= stats["counts"]["feature_points"] > 0, "feature points keep their integers"
    moved = np.sqrt((np.asarray(out.x) - np.asarray(inp.x)[src]) ** 2 + (np.asarray(out.y) - np.asarray(inp.y)[src]) ** 2)
    assert moved.max() < 3.0, "a representative stands near its source"


def simplify(tools, tmp_path, src, dst, *flags):
    stats = tmp_path / "stats.json"
    r = subprocess.run([str(tools / "pcd_simplify"), str(src), str(dst), "--quiet", "--stats", str(stats), *flags],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return json.loads(stats.read_text())


@pytest.mark.parametrize("version,fmt", CASES, ids=[f"{v}-fmt{f}" for v, f in CASES])
def test_las_round_trip_keeps_every_dimension(tools, tmp_path, version, fmt):
    inp = make_input(tmp_path / "in.las", version, fmt, extra=version == "1.4" and fmt in (1, 6, 10))
    stats = simplify(tools, tmp_path, tmp_path / "in.las", tmp_path / "out.las")
    check_output(inp, laspy.read(tmp_path / "out.las"), stats)


@pytest.mark.parametrize("version,fmt", [("1.2", 0), ("1.2", 3), ("1.3", 5), ("1.4", 6), ("1.4", 8), ("1.4", 10)])
def test_laz_round_trip_keeps_every_dimension(tools, tmp_path, version, fmt):
    inp = make_input(tmp_path / "in.laz", version, fmt, extra=fmt == 6)
    stats = simplify(tools, tmp_path, tmp_path / "in.laz", tmp_path / "out.laz")
    out = laspy.read(tmp_path / "out.laz")
    assert out.header.are_points_compressed
    check_output(inp, out, stats)
    # LAZ in, LAS out, and the same points.
    simplify(tools, tmp_path, tmp_path / "in.laz", tmp_path / "out.las")
    plain = laspy.read(tmp_path / "out.las")
    assert not plain.header.are_points_compressed
    assert np.asarray(plain.points.array).tobytes() == np.asarray(out.points.array).tobytes()


@pytest.mark.parametrize("version,fmt,ext", [("1.2", 3, "laz"), ("1.3", 1, "las"), ("1.4", 6, "laz"),
                                             ("1.4", 10, "las")])
def test_stream_reads_and_writes_las_and_laz_keeping_every_dimension(tools, tmp_path, version, fmt, ext):
    """--stream reads the input a chunk at a time and writes the output the same way, in tiles."""
    inp = make_input(tmp_path / f"in.{ext}", version, fmt, extra=fmt == 6)
    stats = simplify(tools, tmp_path, tmp_path / f"in.{ext}", tmp_path / f"out.{ext}",
                     "--stream", "--tile-points", "4000")
    assert len(stats["tiles"]["list"]) >= 2
    out = laspy.read(tmp_path / f"out.{ext}")
    assert out.header.are_points_compressed == (ext == "laz")
    check_output(inp, out, stats)
    # The same points in the other encoding.
    other = "las" if ext == "laz" else "laz"
    simplify(tools, tmp_path, tmp_path / f"in.{ext}", tmp_path / f"out.{other}", "--stream", "--tile-points", "4000")
    assert np.asarray(laspy.read(tmp_path / f"out.{other}").points.array).tobytes() == \
        np.asarray(out.points.array).tobytes()


def test_pcd_to_las_gets_a_scale_that_keeps_the_coordinates(tools, tmp_path):
    inp = make_input(tmp_path / "in.las", "1.2", 0)
    # LAS -> PCD (x y z as double) -> LAS: the new header's scale is a power of ten fine enough.
    simplify(tools, tmp_path, tmp_path / "in.las", tmp_path / "mid.pcd")
    simplify(tools, tmp_path, tmp_path / "mid.pcd", tmp_path / "out.las")
    out = laspy.read(tmp_path / "out.las")
    assert out.header.version == "1.2" and out.header.point_format.id == 0
    s = out.header.scales[0]
    assert s <= 1e-5 and np.isclose(np.log10(s), np.round(np.log10(s)))
    src = np.full(65536, -1, np.int64)
    src[np.asarray(inp.intensity)] = np.arange(N)
    k = src[np.asarray(out.intensity)]
    assert (k >= 0).all()
    near = np.abs(np.asarray(out.x) - np.asarray(inp.x)[k]) < 3.0
    assert near.all()


def refused(tools, tmp_path, data, name="bad.las"):
    bad = tmp_path / name
    bad.write_bytes(data)
    out = tmp_path / "o.las"
    r = subprocess.run([str(tools / "pcd_simplify"), str(bad), str(out), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 3, r.stderr
    assert not out.exists() and len(list(tmp_path.glob("o.las*"))) == 0
    assert r.stderr.count("\n") == 1 and str(bad) in r.stderr
    return r.stderr


def test_malformed_las_is_refused_with_exit_3_and_nothing_written(tools, tmp_path):
    make_input(tmp_path / "in.las", "1.4", 3)
    good = bytearray((tmp_path / "in.las").read_bytes())

    def patched(offset, fmt, value):
        b = bytearray(good)
        b[offset:offset + np.dtype(fmt).itemsize] = np.array([value], fmt).tobytes()
        return bytes(b)

    assert "truncated" in refused(tools, tmp_path, bytes(good[: len(good) // 2]))
    assert "truncated" in refused(tools, tmp_path, patched(247, "<u8", 10 * N))            # point count lies
    assert "truncated" in refused(tools, tmp_path, patched(247, "<u8", 2**40))
    assert "disagree" in refused(tools, tmp_path, patched(107, "<u4", 10 * N))              # legacy count
    assert "record length" in refused(tools, tmp_path, patched(105, "<u2", 20))            # shorter than format 3's
    assert "point format" in refused(tools, tmp_path, patched(104, "<u1", 11))
    assert "outside the file" in refused(tools, tmp_path, patched(96, "<u4", len(good) + 10))  # point data offset
    assert "VLR" in refused(tools, tmp_path, patched(100, "<u4", 1000))                     # VLR count
    assert "LASF" in refused(tools, tmp_path, b"LASX" + bytes(good[4:]))
    assert "truncated" in refused(tools, tmp_path, bytes(good[:100]))
    # A LAS 1.4 file cut in its EVLR; a LAZ whose compressed points are cut short.
    assert "EVLR" in refused(tools, tmp_path, bytes(good[: len(good) - 1000]))
    make_input(tmp_path / "in.laz", "1.2", 3)
    laz = (tmp_path / "in.laz").read_bytes()
    assert "compressed" in refused(tools, tmp_path, laz[: len(laz) * 2 // 3], "cut.laz")


def test_laz_with_more_extra_bytes_than_the_codec_holds_is_refused(tools, tmp_path):
    """laspy (with lazrs) writes records of 1,032 extra bytes (129 doubles), past the 1,024 that
    pcl_ecs reads and writes as LAZ: the LAZ is refused as a bad file, its LAS twin is simplified,
    and a LAZ output of those records is refused before any work."""
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dims([laspy.ExtraBytesParams(name=f"e{k}", type=np.float64) for k in range(129)])
    header.scales = SCALE
    header.offsets = OFFSET
    las = laspy.LasData(header)
    place_on_sphere(las)
    las.write(tmp_path / "wide.laz")
    las.write(tmp_path / "wide.las")
    assert laspy.read(tmp_path / "wide.laz").header.point_format.num_extra_bytes == 1032
    assert "1032 extra bytes" in refused(tools, tmp_path, (tmp_path / "wide.laz").read_bytes(), "bad.laz")
    simplify(tools, tmp_path, tmp_path / "wide.las", tmp_path / "o.las")
    assert laspy.read(tmp_path / "o.las").header.point_format.num_extra_bytes == 1032
    out = tmp_path / "o.laz"
    r = subprocess.run([str(tools / "pcd_simplify"), str(tmp_path / "wide.las"), str(out), "--quiet"],
                       capture_output=True, text=True)
    assert r.returncode == 4 and "1032 extra bytes" in r.stderr, r.stderr
    assert not out.exists() and len(list(tmp_path.glob("o.laz*"))) == 0


@pytest.mark.parametrize("version,fmt,ext", [("1.2", 3, "las"), ("1.2", 3, "laz"), ("1.4", 6, "las"), ("1.4", 6, "laz")])
def test_labels_and_radii_are_extra_dimensions_laspy_reads(tools, tmp_path, version, fmt, ext):
    """--labels --radii with a LAS / LAZ output: laspy finds ecs_label (uint8) and ecs_radius
    (float32) after the input's own dimensions (a float32 extra dimension in LAS 1.4), every one of
    which is still its source point's; the labels count the feature points the stats count, a
    feature point stands for no ball, and the balls' radii are those the stats report."""
    inp = make_input(tmp_path / f"in.{ext}", version, fmt, extra=version == "1.4")
    out = tmp_path / f"out.{ext}"
    stats = simplify(tools, tmp_path, tmp_path / f"in.{ext}", out, "--labels", "--radii")
    got = laspy.read(out)
    assert list(got.point_format.dimension_names) == list(inp.point_format.dimension_names) + ["ecs_label", "ecs_radius"]
    assert got["ecs_label"].dtype == np.uint8 and got["ecs_radius"].dtype == np.float32
    source = np.full(65536, -1, np.int64)
    source[np.asarray(inp.intensity)] = np.arange(N)
    src = source[np.asarray(got.intensity)]
    assert (src >= 0).all()
    for d in dims(inp):
        assert np.asarray(got[d]).tobytes() == np.asarray(inp[d])[src].tobytes(), d
    label = np.asarray(got["ecs_label"])
    radius = np.asarray(got["ecs_radius"])
    assert set(np.unique(label)) == {1, 2}
    assert (label == 1).sum() == stats["counts"]["feature_points"]
    assert (radius[label == 1] == 0).all()
    balls = radius[label == 2]
    assert (balls >= 0).all() and (balls > 0).mean() > 0.5
    assert (label == 2).sum() == stats["counts"]["balls"]
    # Our reader gives the extra dimensions as fields of their own, as laspy does.
    ours = pcl_ecs.read(str(out))
    for d in got.point_format.extra_dimension_names:
        assert np.asarray(ours[d]).tobytes() == np.asarray(got[d]).tobytes(), d


def test_labels_and_radii_past_what_laz_holds_are_refused_before_any_work(tools, tmp_path):
    """Records of 1,020 extra bytes: --radii makes them 1,024, which LAZ holds; --labels --radii
    would make 1,025: refused with exit 4 before any work, nothing written."""
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dims([laspy.ExtraBytesParams(name=f"e{k}", type=np.float64) for k in range(127)] +
                          [laspy.ExtraBytesParams(name="tag", type=np.uint32)])
    header.scales = SCALE
    header.offsets = OFFSET
    las = laspy.LasData(header)
    place_on_sphere(las)
    las.write(tmp_path / "in.las")
    simplify(tools, tmp_path, tmp_path / "in.las", tmp_path / "r.laz", "--radii")
    got = laspy.read(tmp_path / "r.laz")
    assert got.header.point_format.num_extra_bytes == 1024
    assert list(got.point_format.extra_dimension_names)[-2:] == ["tag", "ecs_radius"]
    out = tmp_path / "o.laz"
    r = subprocess.run([str(tools / "pcd_simplify"), str(tmp_path / "in.las"), str(out), "--labels", "--radii"],
                       capture_output=True, text=True)
    assert r.returncode == 4 and "1025 extra bytes" in r.stderr, r.stderr
    assert len(list(tmp_path.glob("o.laz*"))) == 0
