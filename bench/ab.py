#!/usr/bin/env python3
"""A change, measured the way docs/RESULTS.md judges it: two pcd_simplify builds (or one build with
two sets of flags) run on every shared scan of the halves at 10%, 3% and 1% kept (--target-ratio),
each output scored by pcl_ecs_eval (with the reference mesh where there is one), and per half and
metric the median and the range of new ÷ base. Below 1 the change helps that metric.

    python3 bench/ab.py --flags "--alpha 9"                       # flags against the defaults
    python3 bench/ab.py --base-build /tmp/old-build               # this build against another
    python3 bench/ab.py --flags "--alpha 9" --only kinect,part --runs --json ab.json
    python3 bench/ab.py --bar                                     # this build against the peers

--bar runs one side only, at the sizes bench_peers targets (bench/results/peers.json), and prints
the bar lines docs/RESULTS.md would show with pcl_ecs's rows replaced by those runs (the peers'
rows as they are in peers.json).

Choose on the tuning half, read on the checking half (docs/RESULTS.md). A run that fails is
reported and left out of both sides. Takes about 5 minutes a side on a 2-core machine.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile

from rules import HALVES, METRICS, NAMES, RATIOS, ROOT, run


def measure(build, flags, data, work, runs, sizes=None):
    """pcl_ecs_eval's metrics of every (input, ratio) in `runs` (at sizes[(input, ratio)] points when
    given); None for a run that failed (its command is printed to stderr)."""
    scores = {}
    for _, src, mesh, ratio in runs:
        try:
            size = sizes[(src, ratio)] if sizes else None
            scores[(src, ratio)] = run(build, data, work, src, mesh, ratio, flags, size)
        except subprocess.CalledProcessError as e:
            scores[(src, ratio)] = None
            print(f"{build}: {src} at {ratio:g} failed (exit {e.returncode}): {' '.join(e.cmd)}", file=sys.stderr)
    return scores


def summary(runs, base, new, show_runs):
    lines = []
    for half in dict.fromkeys(h for h, _, _, _ in runs):
        lines += [f"{half} half: new ÷ base, median (range, worst run)"]
        if not any(h == half and base.get((src, r)) and new.get((src, r)) for h, src, _, r in runs):
            lines.append("  no run completed on both sides")
        for key, title in METRICS:
            ratios = []
            for h, src, _, ratio in runs:
                a, b = base.get((src, ratio)), new.get((src, ratio))
                if h == half and a and b and a.get(key) and b.get(key) is not None:
                    ratios.append((b[key] / a[key], f"{src.split('.')[0]}@{ratio:g}"))
            if not ratios:
                continue
            values = [r for r, _ in ratios]
            worst = max(ratios)
            lines.append(f"  {title:14s} {statistics.median(values):.3f} ({min(values):.2f}-{max(values):.2f}, "
                         f"worst {worst[1]}) over {len(values)} runs")
            if show_runs:
                lines.append("    " + "  ".join(f"{name} {r:.2f}" for r, name in ratios))
    return lines


def bar(make_results, peers, runs, new):
    """docs/RESULTS.md's bar lines per half (make_results' reading), pcl_ecs's rows of `peers` replaced
    by `new`."""
    entries = []
    for entry in peers:
        src = next((s for s, name in NAMES.items() if name == entry["input"]), None)
        scores = new.get((src, entry["ratio"]))
        if not scores:
            continue
        entry = json.loads(json.dumps(entry))
        for row in entry["methods"]:
            if row["method"] == "pcl_ecs":
                row.pop("error", None)
                row["size"] = scores["simplified_points"]
                row.update({k: scores[k] for k, _ in METRICS if scores.get(k) is not None})
        entries.append(entry)
    lines = []
    for half in dict.fromkeys(h for h, _, _, _ in runs):
        _, summary, _ = make_results.half_table(entries, half)
        lines += [f"{half} half (ours ÷ best peer):"] + ["  " + line for line in make_results.bar_lines(summary)]
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="the build measured (new)")
    ap.add_argument("--base-build", help="the build it is compared with (default: --build)")
    ap.add_argument("--flags", default="", help="pcd_simplify flags of the new side, quoted")
    ap.add_argument("--base-flags", default="", help="pcd_simplify flags of the base side, quoted")
    ap.add_argument("--halves", default="tuning,checking", help="comma-separated: tuning, checking")
    ap.add_argument("--ratios", default=",".join(str(r) for r in RATIOS), help="kept ratios, comma-separated")
    ap.add_argument("--only", help="only inputs whose file name contains one of these, comma-separated")
    ap.add_argument("--runs", action="store_true", help="print every run's ratio too")
    ap.add_argument("--json", help="write every run's metrics, both sides, to this file")
    ap.add_argument("--bar", action="store_true",
                    help="run the new side only, at bench_peers' sizes, and print the bar against the peers")
    ap.add_argument("--peers", default=os.path.join(ROOT, "bench", "results", "peers.json"),
                    help="the peers' rows for --bar (bench_peers' output)")
    ap.add_argument("--data", default=os.environ.get("PCL_ECS_SHARED_DATA_DIR", os.path.join(ROOT, "..", "shared", "data")))
    args = ap.parse_args()
    base_build = args.base_build or args.build
    if not args.bar and base_build == args.build and args.flags == args.base_flags:
        ap.error("nothing to compare: give --flags, --base-flags or --base-build (or --bar)")
    for build in {args.build, base_build}:
        for tool in ("pcd_simplify", "pcl_ecs_eval"):
            if not os.access(os.path.join(build, "tools", tool), os.X_OK):
                ap.error(f"{os.path.join(build, 'tools', tool)} is missing: build with -DPCL_ECS_BUILD_TOOLS=ON")
    halves = args.halves.split(",")
    unknown = [h for h in halves if h not in HALVES]
    if unknown:
        ap.error(f"unknown half {unknown[0]!r}: the halves are {', '.join(HALVES)}")
    ratios = [float(r) for r in args.ratios.split(",")]
    only = args.only.split(",") if args.only else None
    runs = [(h, src, mesh, r) for h in halves for src, mesh in HALVES[h] for r in ratios
            if not only or any(o in src for o in only)]
    if not runs:
        ap.error("no shared input matches --only")
    if args.bar:
        try:
            import make_results  # noqa: E402 (its plots need matplotlib: only --bar reads it)
        except ImportError as e:
            ap.error(f"--bar reads bench/make_results.py, which needs {e.name}: run it with bench/.venv/bin/python "
                     "(bash bench/run_peers.sh makes it) or pip install -r bench/requirements.txt")
        try:
            with open(args.peers) as f:
                peers = json.load(f)
        except (OSError, ValueError) as e:
            ap.error(f"--bar needs the peers' rows: {args.peers}: {e}")
        sizes = {(src, e["ratio"]): e["target"] for e in peers for src, name in NAMES.items() if name == e["input"]}
        runs = [run_ for run_ in runs if (run_[1], run_[3]) in sizes]
        if not runs:
            ap.error(f"no run of these halves and ratios is in {args.peers}")
        with tempfile.TemporaryDirectory() as work:
            new = measure(args.build, shlex.split(args.flags), args.data, work, runs, sizes)
        print("\n".join(bar(make_results, peers, runs, new)))
        if args.json:
            with open(args.json, "w") as f:
                json.dump([{"input": src, "half": h, "ratio": r, "size": sizes[(src, r)], "new": new[(src, r)]}
                           for h, src, _, r in runs], f, indent=1)
        return
    with tempfile.TemporaryDirectory() as work:
        base = measure(base_build, shlex.split(args.base_flags), args.data, work, runs)
        new = measure(args.build, shlex.split(args.flags), args.data, work, runs)
    print("\n".join(summary(runs, base, new, args.runs)))
    if args.json:
        with open(args.json, "w") as f:
            json.dump([{"input": src, "half": h, "ratio": r, "base": base[(src, r)], "new": new[(src, r)]}
                       for h, src, _, r in runs], f, indent=1)


if __name__ == "__main__":
    main()
