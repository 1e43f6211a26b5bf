"""pcl_ecs.distributed: the out-of-core run on a Dask LocalCluster of worker processes gives the
bytes of `pcd_simplify --stream` on the same input, also when a worker is killed in a task or the
driver is stopped and started again; a bad input stops the run with the file and the reason.
"""
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

distributed = pytest.importorskip("dask.distributed")

import pcl_ecs  # noqa: E402
from pcl_ecs.distributed import simplify_distributed  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
MESH = ROOT.parent / "shared" / "data" / "bunny_mesh.ply"
FLAGS = ["--memory-limit", "256M", "--tile-points", "400000", "--terr", "1e-3"]
PARAMS = dict(memory_limit="256M", tile_points=400000, error_threshold=1e-3)


@pytest.fixture(scope="module")
def scan(tools, tmp_path_factory):
    """A 5M-point scan and the output of pcd_simplify --stream on it."""
    d = tmp_path_factory.mktemp("dist")
    subprocess.run([str(tools / "pcd_make_scan"), str(MESH), str(d / "scan.pcd"), "--points", "5000000",
                    "--scans", "6", "--quiet"], check=True)
    subprocess.run([str(tools / "pcd_simplify"), str(d / "scan.pcd"), str(d / "ref.pcd"), "--stream", "--quiet",
                    "--scratch", str(d / "ref-scratch"), *FLAGS], check=True)
    return d


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        with distributed.Client(c) as client:
            yield client


def test_two_workers_give_the_bytes_of_one_process(scan, cluster, tmp_path):
    s = simplify_distributed(scan / "scan.pcd", tmp_path / "out.pcd", cluster, tmp_path / "scratch", **PARAMS)
    assert (tmp_path / "out.pcd").read_bytes() == (scan / "ref.pcd").read_bytes()
    assert s["tiles"] >= 8 and s["tasks_skipped"] == 0
    assert s["tasks_run"] >= 3 * s["tiles"]  # A, B, C (and D) of every tile
    assert s["counts"]["finite_points"] == 5_000_000
    assert not (tmp_path / "scratch").exists(), "the scratch is removed on success"
    # Both workers took tasks.
    assert len(cluster.scheduler_info()["workers"]) == 2


def test_laz_in_and_out_as_pcd_simplify_stream(tools, cluster, tmp_path):
    laz = tmp_path / "scan.laz"
    subprocess.run([str(tools / "pcd_make_scan"), str(MESH), str(laz), "--points", "600000", "--quiet",
                    "--scale", "100", "--offset", "512000", "4100000", "200"], check=True)
    flags = ["--memory-limit", "128M", "--tile-points", "100000"]
    subprocess.run([str(tools / "pcd_simplify"), str(laz), str(tmp_path / "ref.laz"), "--stream", "--quiet", *flags],
                   check=True)
    simplify_distributed(laz, tmp_path / "out.laz", cluster, tmp_path / "scratch", memory_limit="128M",
                         tile_points=100000)
    assert (tmp_path / "out.laz").read_bytes() == (tmp_path / "ref.laz").read_bytes()


def test_three_las_tiles_as_one_cloud_as_pcd_simplify_stream(tools, cluster, tmp_path):
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    for i in range(3):
        subprocess.run([str(tools / "pcd_make_scan"), str(MESH), str(tiles / f"t{i}.las"), "--points", "200000",
                        "--quiet", "--seed", str(i + 1), "--scale", "100", "--offset", str(512000 + 15 * i),
                        "4100000", "200"], check=True)
    flags = ["--memory-limit", "256M", "--tile-points", "100000"]
    subprocess.run([str(tools / "pcd_simplify"), str(tiles), str(tmp_path / "ref.laz"), "--stream", "--quiet", *flags],
                   check=True)
    s = simplify_distributed(tiles, tmp_path / "out.laz", cluster, tmp_path / "scratch", memory_limit="256M",
                             tile_points=100000)
    assert s["counts"]["input_points"] == 600000
    assert (tmp_path / "out.laz").read_bytes() == (tmp_path / "ref.laz").read_bytes()
    # The tiles listed one by one are the same cloud.
    simplify_distributed(sorted(tiles.iterdir()), tmp_path / "listed.laz", cluster, tmp_path / "scratch2",
                         memory_limit="256M", tile_points=100000)
    assert (tmp_path / "listed.laz").read_bytes() == (tmp_path / "ref.laz").read_bytes()


def test_a_worker_killed_in_a_task_changes_nothing(scan, tmp_path):
    # The first worker to run stage C of tile 1 kills itself (SIGKILL) while it runs; Dask gives the
    # task to another worker (the nanny restarts the dead one).
    marker = tmp_path / "killed"
    env = dict(os.environ, PCL_ECS_TEST_KILL_IN_TASK=f"C1:{marker}")
    old = dict(os.environ)
    os.environ.update(env)
    try:
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as c, distributed.Client(c) as client:
            simplify_distributed(scan / "scan.pcd", tmp_path / "out.pcd", client, tmp_path / "scratch", **PARAMS)
    finally:
        os.environ.clear()
        os.environ.update(old)
    assert marker.exists(), "a worker was killed"
    assert (tmp_path / "out.pcd").read_bytes() == (scan / "ref.pcd").read_bytes()


def test_a_driver_stopped_and_started_again_skips_what_was_done(scan, tmp_path):
    cmd = [sys.executable, "-m", "pcl_ecs.distributed", str(scan / "scan.pcd"), str(tmp_path / "out.pcd"),
           "--local", "2", "--scratch", str(tmp_path / "scratch"), "--quiet", *FLAGS]
    p = subprocess.Popen(cmd, start_new_session=True)
    done = []
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and p.poll() is None:
        done = list((tmp_path / "scratch").glob("a/*.sum"))
        if len(done) >= 2:
            break
        time.sleep(0.05)
    os.killpg(p.pid, signal.SIGKILL)  # the driver and its cluster
    p.wait()
    assert len(done) >= 2, "stopped after some tiles' first step"
    assert not (tmp_path / "out.pcd").exists()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as c, distributed.Client(c) as client:
        s = simplify_distributed(scan / "scan.pcd", tmp_path / "out.pcd", client, tmp_path / "scratch", **PARAMS)
    assert s["tasks_skipped"] >= len(done)
    assert (tmp_path / "out.pcd").read_bytes() == (scan / "ref.pcd").read_bytes()


def test_a_corrupt_tile_among_the_inputs_stops_the_run_naming_it(tools, cluster, tmp_path):
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    for i in range(3):
        subprocess.run([str(tools / "pcd_make_scan"), str(MESH), str(tiles / f"t{i}.laz"), "--points", "100000",
                        "--quiet", "--seed", str(i + 1)], check=True)
    bad = tiles / "t1.laz"
    data = bad.read_bytes()
    bad.write_bytes(data[: len(data) // 2])  # a transfer cut short
    with pytest.raises(ValueError, match="t1.laz.*truncated or corrupt"):
        simplify_distributed(tiles, tmp_path / "out.laz", cluster, tmp_path / "scratch", memory_limit="512M")
    assert not (tmp_path / "out.laz").exists()
    # The command line says the same, exit 3.
    r = subprocess.run([sys.executable, "-m", "pcl_ecs.distributed", str(tiles), str(tmp_path / "out.laz"),
                        "--local", "1", "--scratch", str(tmp_path / "scratch"), "--quiet", "--memory-limit", "512M"],
                       capture_output=True, text=True)
    assert r.returncode == 3 and "t1.laz" in r.stderr, r.stderr
    assert not (tmp_path / "out.laz").exists()
