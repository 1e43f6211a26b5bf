"""The out-of-core run (`pcd_simplify --stream`) on a Dask cluster: the same plan, the same tile
tasks and the same bytes as one process, each task run by whichever worker Dask gives it.

    from dask.distributed import Client
    from pcl_ecs.distributed import simplify_distributed
    summary = simplify_distributed("big.laz", "small.laz", Client("tcp://scheduler:8786"),
                                   scratch="/shared/tmp", memory_limit="2G", error_threshold=1e-3)

or from a shell: `python -m pcl_ecs.distributed IN... OUT --scheduler tcp://HOST:PORT` (`--local N`
for a LocalCluster of N worker processes), with pcd_simplify --stream's flags.

The driver (this process) reads the input's header, plans and splits the scan into tiles in the
scratch directory (as `--stream` does), then submits each tile's steps as Dask tasks with their
dependencies: A (neighbourhoods, normals, the measures) on every tile; B (features, the densities)
once every A is done; C (the cover) colour by colour once every B is done; D (the gap bound) colour
by colour after every C. A task reads its inputs from the scratch and writes its outputs there
atomically, so a task that runs twice (a lost worker, a retry, a rerun after the driver stopped)
writes the same files, and one already done returns at once. The global statistics are summed in
tile order by whoever reads them, and the plan counts a fixed size for the process, so the output
never depends on which worker ran what: it is the file `pcd_simplify --stream` writes for the same
input, parameters, --memory-limit and --tile-points. The scratch must be a directory every worker
and the driver can reach (a shared filesystem; a local path for a LocalCluster); the input and
output paths too.

Needs the `distributed` extra: pip install .[distributed].
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence

from . import _core, _parameters

__all__ = ["simplify_distributed", "main"]


def _run_args(inputs, output, memory_limit, scratch, tile_points, keep_scratch):
    if isinstance(memory_limit, str):
        memory_limit = _core._parse_byte_size(memory_limit)
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    files = tuple(os.path.abspath(f) for f in _core._record_inputs([os.fspath(i) for i in inputs]))
    return (files, os.path.abspath(os.fspath(output)), int(memory_limit or 0), os.path.abspath(os.fspath(scratch)),
            int(tile_points or 0), bool(keep_scratch))


def _open(args, params: Dict[str, Any]):
    inputs, output, memory_limit, scratch, tile_points, keep = args
    return _core._TiledRun(list(inputs), output, _parameters(params), memory_limit, scratch, tile_points, keep)


def _task(args, params: Dict[str, Any], stage: str, tile: int, *after) -> bool:
    """One step of one tile, in a worker: True when it ran, False when it was done already."""
    if "threads" not in params:
        # As many threads as the worker has (threads_per_worker): a tile's result does not depend
        # on them, and more than that would oversubscribe the machine's cores.
        from dask.distributed import get_worker
        try:
            params = dict(params, threads=get_worker().state.nthreads)
        except ValueError:  # not in a worker (called directly)
            pass
    # As pcd_simplify does: freed memory stays in the worker for the next task instead of coming
    # back as fresh pages the kernel faults in and zeroes again (about a tenth of a stage A task).
    _core._keep_freed_memory()
    run = _open(args, params)
    run.prepare(False)
    _kill_for_tests(stage, tile)
    return run.run_task(stage, tile)


def _kill_for_tests(stage: str, tile: int) -> None:
    """For tests (PCL_ECS_TEST_KILL_IN_TASK=STAGE TILE:MARKER, e.g. C1:/tmp/killed): the first
    worker to run that task kills itself with SIGKILL 20 ms into it (and creates MARKER)."""
    hook = os.environ.get("PCL_ECS_TEST_KILL_IN_TASK")
    if not hook:
        return
    task, _, marker = hook.partition(":")
    if task != f"{stage}{tile}":
        return
    try:
        fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return
    os.close(fd)
    import signal
    import threading
    threading.Timer(0.02, os.kill, (os.getpid(), signal.SIGKILL)).start()


def simplify_distributed(inputs: Any, output: str, client: Any, scratch: str, *,
                         memory_limit: Any = "1G", tile_points: int = 0, keep_scratch: bool = False,
                         progress: bool = False, retries: int = 2, **params: Any) -> Dict[str, Any]:
    """Simplify `inputs` (a PCD, LAS or LAZ file, a directory of them, or a list of either: their
    points as one cloud, as `pcd_simplify --stream IN... OUT`) into `output` (PCD, LAS or LAZ) on
    the workers of `client` (a dask.distributed.Client). `scratch` is a directory the driver and every worker can
    reach; `memory_limit` (bytes or "2G") sizes the tiles as `--memory-limit` does, so that each
    task holds at most two tiles' worth (a worker runs tasks on as many threads as it has:
    `nthreads=1` per worker keeps one task per worker); `params` are those of `simplify`
    (error_threshold, ...). `retries` re-runs a task that raised (tasks are idempotent); a task of
    a lost worker is run again by Dask anyway. With `progress`, Dask's progress bar on the terminal.

    Returns the summary: the counts of `pcd_simplify --stream --stats`, `tiles`, `seconds`,
    `tasks_run` and `tasks_skipped` (done by an earlier, interrupted run). A bad input raises
    ValueError naming the file; nothing is written at `output` unless the run succeeds."""
    from dask.distributed import wait
    from dask.distributed import progress as dask_progress

    t0 = time.monotonic()
    args = _run_args(inputs, output, memory_limit, scratch, tile_points, keep_scratch)
    checked = _parameters(params)  # bad names and values fail here, before any work
    driver = _open(args, params)
    tiles = driver.prepare(True)
    token = f"{abs(hash((args, tuple(sorted(params.items()))))):x}"

    def submit(stage: str, tile: int, after: Sequence[Any]):
        return client.submit(_task, args, params, stage, tile, *after, key=f"pcl_ecs-{stage}{tile}-{token}",
                             pure=False, retries=retries)

    def finish(futures: List[Any]) -> List[bool]:
        if progress:
            dask_progress(futures)
        wait(futures)
        for f in futures:
            if f.status == "error":
                for g in futures:
                    g.cancel()
                f.result()  # raises the task's error, which names the file and the reason
        return client.gather(futures)

    a = [submit("A", t, []) for t in range(tiles)]
    b = [submit("B", t, a) for t in range(tiles)]
    ran = finish(a + b)
    colours = driver.colours()
    later: List[Any] = []
    for stage in ("C", "D") if checked.max_gap_factor > 0 else ("C",):
        before = list(later)  # every task of the previous stage
        for c in range(max(colours) + 1):
            this = [submit(stage, t, before) for t in range(tiles) if colours[t] == c]
            later += this
            before = before + this
    ran += finish(later)
    summary = driver.finish()
    summary["seconds"] = time.monotonic() - t0
    summary["tasks_run"] = sum(1 for r in ran if r)
    summary["tasks_skipped"] = sum(1 for r in ran if not r)
    return summary


def summary_line(output: str, s: Dict[str, Any], error_threshold: float) -> str:
    """The line pcd_simplify --stream prints at the end."""
    c = s["counts"]
    merged = f" ({c['merged_points']} coincident points merged)" if c["merged_points"] else ""
    rate = c["input_points"] / max(1e-9, s["seconds"]) / 1e6
    return (f"{output}: {c['finite_points']} -> {c['output_points']} points "
            f"({100.0 * c['output_points'] / max(1, c['finite_points']):.2f}%){merged}: "
            f"{c['feature_points']} features, {c['balls']} balls; T_err {error_threshold:.3g}, "
            f"max error {s['max_error']:.3g} L; {s['tiles']} tiles; {s['seconds']:.2f} s ({rate:.2f} M points/s)")


def _method_flags():
    """The method's parameters as pcd_simplify spells them (the C++ parameter table), without the
    target-size ones (the out-of-core run takes a T_err) and the deviation's (measured in memory
    only)."""
    return [row for row in _core._parameter_table()
            if not row["name"].startswith("target-") and row["name"] not in ("max-deviation", "report-deviation")]


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m pcl_ecs.distributed",
        description="pcd_simplify --stream on a Dask cluster: the same output, bytes for bytes, with the tiles' "
                    "steps run by the cluster's workers. INPUT and OUTPUT are .pcd, .las or .laz; the scratch "
                    "directory, the input and the output must be reachable from every worker.")
    ap.add_argument("inputs", nargs="+", metavar="INPUT",
                    help="a .pcd, .las or .laz file, or a directory of them (simplified as one cloud)")
    ap.add_argument("output", metavar="OUTPUT")
    where = ap.add_mutually_exclusive_group(required=True)
    where.add_argument("--scheduler", metavar="ADDRESS", help="a running scheduler, e.g. tcp://HOST:8786")
    where.add_argument("--local", metavar="N", type=int, help="start a LocalCluster of N worker processes")
    ap.add_argument("--scratch", required=True, metavar="DIR", help="scratch directory every worker can reach")
    ap.add_argument("--memory-limit", default="1G", metavar="SIZE",
                    help="the tiles' memory budget, as pcd_simplify --stream (default 1G)")
    ap.add_argument("--tile-points", type=int, default=0, metavar="N", help="largest tile (default: from the limit)")
    ap.add_argument("--keep-scratch", action="store_true", help="keep the scratch directory after success")
    ap.add_argument("--stats", metavar="FILE", help="write the run's summary as JSON to FILE")
    method = ap.add_argument_group("the method (pcd_simplify's flags)")
    for row in _method_flags():
        if row["metavar"]:
            method.add_argument("--" + row["name"], dest="p_" + row["field"], default=None, metavar=row["metavar"],
                                help=f"{row['help']}; {row['range']}")
        else:
            method.add_argument("--" + row["name"], dest="p_" + row["field"], action="store_true", help=row["help"])
    ap.add_argument("--quiet", action="store_true", help="no progress bar and no summary line")
    o = ap.parse_args(argv)
    chosen, given = _core.Parameters(), []
    for row in _method_flags():
        value = getattr(o, "p_" + row["field"])
        if value is None or value is False:
            continue
        try:
            _core._set_parameter(chosen, row["name"], "true" if value is True else value)
        except ValueError as e:
            ap.error(str(e))
        given.append(row["field"])
    params = {field: getattr(chosen, field) for field in given}
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        print("python -m pcl_ecs.distributed: needs dask.distributed (pip install .[distributed])", file=sys.stderr)
        return 2
    try:
        if o.local is not None:
            if o.local < 1:
                ap.error("--local needs at least 1 worker")
            cluster = LocalCluster(n_workers=o.local, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(o.scheduler)
        with client:
            s = simplify_distributed(o.inputs, o.output, client, o.scratch, memory_limit=o.memory_limit,
                                     tile_points=o.tile_points, keep_scratch=o.keep_scratch, progress=not o.quiet,
                                     **params)
    except ValueError as e:
        print(f"python -m pcl_ecs.distributed: {e}", file=sys.stderr)
        return 3
    except (RuntimeError, OSError) as e:
        print(f"python -m pcl_ecs.distributed: {e}", file=sys.stderr)
        return 4
    if o.stats:
        import json
        tmp = f"{o.stats}.tmp.{os.getpid()}"
        with open(tmp, "w") as f:
            json.dump(dict(s, tool="python -m pcl_ecs.distributed", inputs=list(o.inputs), output=o.output,
                           parameters=params), f, indent=2)
        os.replace(tmp, o.stats)
    if not o.quiet:
        print(summary_line(o.output, s, params.get("error_threshold", _parameters({}).error_threshold)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
