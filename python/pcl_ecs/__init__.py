"""pcl_ecs: feature-preserving, error-controlled point cloud simplification.

    import numpy as np, pcl_ecs
    r = pcl_ecs.simplify(points, target_ratio=0.1)      # points: (N, 3) float32 or float64
    r.points, r.labels, r.source_index                   # (M, 3) float64, (M,) uint8, (M,) int64
    colours_out = colours[r.source_index]                # any per-point attribute, as the tools do

Every parameter of the C++ library (pcl_ecs::Parameters) is a keyword argument of `simplify` with
the same name, default and validation; see `pcl_ecs.Parameters()` for the defaults and
docs/PYTHON.md for what each does. The same inputs give the same output as `pcd_simplify`.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np

from ._core import Parameters, __version__, laz_supported
from . import _core

__all__ = ["simplify", "read", "write", "reconstruct", "Result", "Parameters", "parameter_names",
           "__version__", "laz_supported"]


def parameter_names() -> Tuple[str, ...]:
    """The keyword arguments `simplify` takes besides the arrays and target_ratio."""
    return tuple(n for n in dir(Parameters) if not n.startswith("_") and n != "validate")


BALL_DTYPE = np.dtype([("centre", "<f8", (3,)), ("centre_index", "<i8"), ("radius", "<f8"),
                       ("tolerance", "<f8"), ("error", "<f8"), ("replaced", "<i8")])


@dataclass
class Result:
    """What `simplify` returns.

    points          (M, 3) float64: the output points, in the input's coordinates
    labels          (M,) uint8: 1 a feature point (an input point kept as it is), 2 a representative
    source_index    (M,) int64: the input row whose attributes each output point carries (a feature
                    point: itself; a representative: the input point it stands on)
    input_to_output (N,) int64: for each input row, the output point that stands for it (-1: not
                    finite)
    balls           structured array (centre, centre_index, radius, tolerance, error, replaced): one
                    row per ball of the cover, in input units
    summary         dict: the same keys as `pcd_simplify --stats` (parameters, counts, geometry,
                    timings_s, target_reached)
    point_radius    (M,) float64: the radius of the ball each output point stands for (0 for a
                    feature point and an input point kept as it is); `reconstruct(points,
                    radius=point_radius)` uses it
    """
    points: np.ndarray
    labels: np.ndarray
    source_index: np.ndarray
    input_to_output: np.ndarray
    balls: np.ndarray
    summary: Dict[str, Any]
    point_radius: Optional[np.ndarray] = None


def _as_points(points: Any) -> np.ndarray:
    a = np.asarray(points)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"points must be an (N, 3) array, not shape {a.shape}")
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    return np.ascontiguousarray(a)


def _optional(a: Any, dtype: Any) -> Optional[np.ndarray]:
    return None if a is None else np.ascontiguousarray(np.asarray(a), dtype=dtype)


def _parameters(params: Dict[str, Any]) -> Parameters:
    p = Parameters()
    known = set(parameter_names())
    for name, value in params.items():
        if name not in known:
            raise TypeError(f"simplify() got an unexpected keyword argument {name!r} "
                            f"(parameters: {', '.join(sorted(known))})")
        try:
            setattr(p, name, value)
        except TypeError as e:
            raise ValueError(f"{name} = {value!r}: {e}") from None
    return p


def simplify(points: Any, *, normals: Any = None, colors: Any = None, intensity: Any = None,
             target_ratio: Optional[float] = None, **params: Any) -> Result:
    """Simplify a point cloud, keeping its sharp features.

    points: (N, 3) float32 or float64 (rows with NaN or inf are left out, as in C++).
    normals: (N, 3), used with use_input_normals=True; colors: (N, 3) or (N, 4) uint8;
    intensity: (N,). They are carried to the output as pcd_simplify carries them (read them back
    with `source_index`); only the coordinates (and normals, when asked) drive the method.
    target_ratio: aim at this fraction of the distinct finite points instead of error_threshold.
    **params: any field of pcl_ecs.Parameters (error_threshold, feature_factor, k_neighbors, ...).
    A bad value raises ValueError with the library's message. The GIL is released while it runs.
    """
    p = _parameters(params)
    bad = p.validate()
    if bad:
        raise ValueError(bad)
    r = _core._simplify(_as_points(points), _optional(normals, np.float32), _optional(colors, np.uint8),
                        _optional(intensity, np.float32), p, float(target_ratio or 0.0))
    balls = np.empty(len(r["ball_radius"]), dtype=BALL_DTYPE)
    balls["centre"] = r["ball_centre"]
    balls["centre_index"] = r["ball_centre_index"]
    balls["radius"] = r["ball_radius"]
    balls["tolerance"] = r["ball_tolerance"]
    balls["error"] = r["ball_error"]
    balls["replaced"] = r["ball_replaced"]
    return Result(points=r["points"], labels=r["labels"], source_index=r["source_index"],
                  input_to_output=r["input_to_output"], balls=balls, summary=json.loads(r["summary_json"]),
                  point_radius=r["point_radius"])


def read(path: str) -> Dict[str, np.ndarray]:
    """Every field of a PCD, PLY, XYZ, LAS or LAZ file, by name (x, y, z, ...): (N,) arrays, or
    (N, count) for a field of count > 1. A bad file raises ValueError saying what is wrong."""
    return _core._read(str(path))


def write(path: str, points: Any, *, normals: Any = None, colors: Any = None, intensity: Any = None,
          fields: Optional[Mapping[str, Any]] = None) -> None:
    """Write points (and normals, uint8 colours, intensity) as .pcd, .ply, .las or .laz, by the
    file name. The file appears only when complete.

    `fields` adds any other per-point values by name: (N,) or (N, count) arrays of integers or
    floats, each kept as its own type in PCD and PLY (what `read` gives back); in LAS / LAZ the
    names of LAS dimensions (classification, gps_time, return_number, point_source_id, ...) go to
    those dimensions and the others become extra dimensions of their name and type (names of up to
    31 characters; an (N, count) array as one dimension a column, NAME_0, NAME_1, ...), which
    laspy, PDAL and CloudCompare read (docs/LAS.md)."""
    extra = None
    if fields is not None:
        extra = {}
        las = str(path).lower().endswith((".las", ".laz"))
        for name, values in fields.items():
            a = np.ascontiguousarray(values)
            if a.dtype == np.bool_:
                a = a.astype(np.uint8)
            if las and a.ndim == 2:
                for c in range(a.shape[1]):
                    extra[f"{name}_{c}"] = np.ascontiguousarray(a[:, c])
            else:
                extra[str(name)] = a
    _core._write(str(path), _as_points(points), _optional(normals, np.float32), _optional(colors, np.uint8),
                 _optional(intensity, np.float32), extra)


def reconstruct(points: Any, radius: Any = None, scan: Any = None,
                scan_to_point: Any = None) -> Tuple[np.ndarray, np.ndarray]:
    """Cocone surface through the points: (vertices (N, 3) float64, triangles (T, 3) int64 indices
    into them), manifold and oriented. Raises ValueError when no surface can be made.

    `radius`, optional, (N,): the radius of the ball each point stands for (`Result.point_radius`
    of `simplify`; 0 for a point kept as it is, which is judged by its nearest neighbour's ball;
    NaN where unknown). Triangles joining two points whose balls do not overlap (farther apart
    than 2 × the sum of their radii) are then refused: they cross gaps, such as between a gear's
    teeth, that the sparse points alone do not show.

    `scan`, optional, (M, 3): the scan the points were simplified from. Tunnels the cocones capped
    on both faces of a part (a bore about one point spacing across) are then opened against it:
    two facing patches of the mesh that span empty space are replaced by a band on the bore's
    wall. `scan_to_point`, optional with it, (M,) int64: the point standing for each scan point
    (`Result.input_to_output` of `simplify`; -1: none); without it, each scan point's nearest."""
    def f64(a: Any) -> np.ndarray:
        return np.ascontiguousarray(np.asarray(a), dtype=np.float64)
    return _core._reconstruct(f64(points), None if radius is None else f64(radius),
                              None if scan is None else f64(scan),
                              None if scan_to_point is None
                              else np.ascontiguousarray(np.asarray(scan_to_point), dtype=np.int64))
