"""Shared fixtures of the Python tests: where the built tools are."""
import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def tools() -> pathlib.Path:
    """The directory of the built tools: $PCL_ECS_TOOLS, else build/tools."""
    d = pathlib.Path(os.environ.get("PCL_ECS_TOOLS", ROOT / "build" / "tools"))
    if not (d / "pcd_simplify").exists():
        pytest.fail(f"pcd_simplify not found in {d}: build first (scripts/build.sh) or set PCL_ECS_TOOLS")
    return d
