# Type stubs of pcl_ecs, so that editors complete simplify's keywords. The defaults are the C++
# library's (pcl_ecs::Parameters); tests/python/test_python_api.py checks that they agree.
from dataclasses import dataclass
from os import PathLike
from typing import Any, Dict, Literal, Mapping, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
laz_supported: bool

class Parameters:
    error_threshold: float
    error_threshold_abs: float
    feature_factor: float
    k_neighbors: int
    error_form: str
    adaptive: bool
    adaptive_factor: float
    radius_cap_factor: float
    target_radius_cap: float
    max_representative_offset: float
    representative_cutoff: float
    max_roughness: float
    representative_fit: bool
    relax_representatives: bool
    feature_spacing: float
    max_gap_factor: float
    target_gap_factor: float
    max_deviation: Union[float, str]
    report_deviation: bool
    seed: int
    use_input_normals: bool
    threads: int
    target_size: int
    def __init__(self) -> None: ...
    def validate(self) -> str: ...

@dataclass
class Result:
    points: npt.NDArray[np.float64]
    labels: npt.NDArray[np.uint8]
    source_index: npt.NDArray[np.int64]
    input_to_output: npt.NDArray[np.int64]
    balls: np.ndarray
    summary: Dict[str, Any]
    point_radius: Optional[npt.NDArray[np.float64]]

def parameter_names() -> Tuple[str, ...]: ...
def simplify(
    points: npt.ArrayLike,
    *,
    normals: Optional[npt.ArrayLike] = None,
    colors: Optional[npt.ArrayLike] = None,
    intensity: Optional[npt.ArrayLike] = None,
    target_ratio: Optional[float] = None,
    error_threshold: float = 0.001,
    error_threshold_abs: float = 0.0,
    feature_factor: float = 6.0,
    k_neighbors: int = 16,
    error_form: Literal["normalized", "paper"] = "normalized",
    adaptive: bool = True,
    adaptive_factor: float = 2.0,
    radius_cap_factor: float = 5.0,
    target_radius_cap: float = 2.5,
    max_representative_offset: float = 0.5,
    representative_cutoff: float = 0.05,
    max_roughness: float = 0.2,
    representative_fit: bool = True,
    relax_representatives: bool = True,
    feature_spacing: float = 0.0,
    max_gap_factor: float = 1.0,
    target_gap_factor: float = 0.6,
    max_deviation: Union[float, str] = 0.0,
    report_deviation: bool = False,
    seed: int = 42,
    use_input_normals: bool = False,
    threads: int = 0,
    target_size: int = 0,
) -> Result: ...
def read(path: Union[str, PathLike]) -> Dict[str, np.ndarray]: ...
def write(
    path: Union[str, PathLike],
    points: npt.ArrayLike,
    *,
    normals: Optional[npt.ArrayLike] = None,
    colors: Optional[npt.ArrayLike] = None,
    intensity: Optional[npt.ArrayLike] = None,
    fields: Optional[Mapping[str, npt.ArrayLike]] = None,
) -> None: ...
def reconstruct(
    points: npt.ArrayLike,
    radius: Optional[npt.ArrayLike] = None,
    scan: Optional[npt.ArrayLike] = None,
    scan_to_point: Optional[npt.ArrayLike] = None,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]: ...
