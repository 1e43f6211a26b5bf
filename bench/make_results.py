#!/usr/bin/env python3
"""docs/RESULTS.md and its plots from bench/results/peers.json (+ peers_sweep.json).

Tables: every input at every size, every method: size, time, peak memory and the pcl_ecs_eval
metrics. Verdicts: the issue-4 bar, checked line by line. Plots: error against output size for
every method on the bunny and the fandisk; the fandisk's points near its sharp edges under each
method.
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
RESULTS = os.path.join(HERE, "results")
IMAGES = os.path.join(ROOT, "docs", "images")

ORDER = ["pcl_ecs", "voxel_grid", "uniform_sampling", "random_sample", "normal_space", "fps",
         "cgal_grid", "cgal_hierarchy", "cgal_wlop"]


def fmt(x, digits=2):
    return "" if x is None else f"{x:.{digits}e}"


def table(entry):
    rows = ["| method | size | time s | peak MiB | surface RMS | surface p99 | coverage mean | coverage max | Hausdorff | edge mean | edge p90 |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for m in entry["methods"]:
        if "error" in m:
            rows.append(f"| {m['label']} | failed: {m['error']} | | | | | | | | | |")
            continue
        edge = (fmt(m["edge_mean"]), fmt(m["edge_p90"])) if m.get("has_mesh") else ("", "")
        name = f"**{m['label']}**" if m["method"] == "pcl_ecs" else m["label"]
        rows.append(f"| {name} | {m['size']} | {m['seconds']:.3f} | {m['peak_extra_mib']:.1f} | {fmt(m['surface_rms'])} | "
                    f"{fmt(m['surface_p99'])} | {fmt(m['coverage_mean'])} | {fmt(m['coverage_max'])} | {fmt(m['hausdorff'])} | "
                    f"{edge[0]} | {edge[1]} |")
    return "\n".join(rows)


def verdict(entry):
    """The issue-4 bar for one input and size."""
    ms = {m["method"]: m for m in entry["methods"] if "error" not in m}
    if "pcl_ecs" not in ms:
        return ["pcl_ecs failed"]
    ours = ms["pcl_ecs"]
    peers = [m for k, m in ms.items() if k != "pcl_ecs"]
    out = []
    if ours.get("has_mesh"):
        best = min(peers, key=lambda m: m["edge_mean"])
        margin = 1 - ours["edge_mean"] / best["edge_mean"]
        need = 0.30 if entry["input"] == "fandisk" else 0.0
        ok = margin > need if need > 0 else ours["edge_mean"] < best["edge_mean"]
        out.append(f"sharp-edge distance: {fmt(ours['edge_mean'])} vs best peer {best['label']} {fmt(best['edge_mean'])} "
                   f"({100 * margin:.0f}% {'below' if margin >= 0 else 'above'}{', needs 30% below' if need else ''}): **{'met' if ok else 'NOT met'}**")
    best = min(peers, key=lambda m: m["surface_rms"])
    ratio = ours["surface_rms"] / best["surface_rms"]
    out.append(f"surface deviation: {fmt(ours['surface_rms'])} vs best peer {best['label']} {fmt(best['surface_rms'])} "
               f"(× {ratio:.2f}, at most 1.05): **{'met' if ratio <= 1.05 else 'NOT met'}**")
    best = min(peers, key=lambda m: m["coverage_max"])
    ratio = ours["coverage_max"] / best["coverage_max"]
    out.append(f"coverage max: {fmt(ours['coverage_max'])} vs best peer {best['label']} {fmt(best['coverage_max'])} "
               f"(× {ratio:.2f}, at most 1.5): **{'met' if ratio <= 1.5 else 'NOT met'}**")
    for k in ("cgal_hierarchy", "cgal_wlop"):
        if k in ms:
            faster = ours["seconds"] < ms[k]["seconds"]
            out.append(f"time against {ms[k]['label']}: {ours['seconds']:.3f} s vs {ms[k]['seconds']:.3f} s: "
                       f"**{'faster' if faster else 'NOT faster'}**")
    return out


def sweep_plots(entries):
    os.makedirs(IMAGES, exist_ok=True)
    made = []
    for name in ("bunny", "fandisk"):
        es = sorted([e for e in entries if e["input"] == name], key=lambda e: e["ratio"])
        if len(es) < 2:
            continue
        metrics = [("surface_rms", "surface deviation RMS (L)"), ("coverage_max", "coverage max (L)")]
        if es[0]["methods"][0].get("has_mesh"):
            metrics.append(("edge_mean", "sharp-edge distance mean (L)"))
        fig, axes = plt.subplots(1, len(metrics), figsize=(5.2 * len(metrics), 4.2))
        for ax, (key, title) in zip(axes, metrics):
            for method in ORDER:
                xs, ys = [], []
                for e in es:
                    for m in e["methods"]:
                        if m["method"] == method and "error" not in m:
                            xs.append(m["size"])
                            ys.append(m[key])
                if xs:
                    style = dict(linewidth=2.5, color="black", marker="o") if method == "pcl_ecs" else dict(marker=".")
                    label = next(m["label"] for m in es[0]["methods"] if m["method"] == method)
                    ax.plot(xs, ys, label=label, **style)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("output points")
            ax.set_title(title)
            ax.grid(True, which="both", alpha=0.3)
        axes[0].legend(fontsize=7)
        fig.suptitle(f"{name}: error against output size")
        fig.tight_layout()
        path = os.path.join(IMAGES, f"results_{name}_error_vs_size.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        made.append(os.path.relpath(path, os.path.join(ROOT, "docs")))
    return made


def edge_picture(workdir, mesh_ply):
    """The fandisk's output points under each method, in one view, those near a sharp edge red."""
    try:
        import numpy as np
    except ImportError:
        return None
    pts = {}
    for method in ORDER:
        f = os.path.join(workdir, f"fandisk_{method}.pcd")
        if os.path.exists(f):
            pts[method] = read_pcd_xyz(f)
    if not pts:
        return None
    fig, axes = plt.subplots(3, 3, figsize=(12, 11))
    for ax, method in zip(axes.flat, ORDER):
        ax.set_axis_off()
        if method not in pts:
            continue
        p = np.asarray(pts[method])
        ax.scatter(p[:, 0], p[:, 1], s=0.4, c=p[:, 2], cmap="viridis")
        ax.set_aspect("equal")
        ax.set_title(f"{method}: {len(p)} points", fontsize=9)
    fig.suptitle("fandisk, same output size (3%), top view coloured by height: sharp edges are where colour jumps")
    fig.tight_layout()
    path = os.path.join(IMAGES, "results_fandisk_methods.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return os.path.relpath(path, os.path.join(ROOT, "docs"))


def read_pcd_xyz(path):
    """Binary PCD with float x y z first (what bench_peers writes)."""
    import struct
    with open(path, "rb") as f:
        header = {}
        while True:
            line = f.readline().decode("ascii").strip()
            k, _, v = line.partition(" ")
            header[k] = v
            if k == "DATA":
                break
        n = int(header["POINTS"])
        sizes = [int(s) for s in header["SIZE"].split()]
        counts = [int(c) for c in header.get("COUNT", " ".join("1" * len(sizes))).split()]
        step = sum(s * c for s, c in zip(sizes, counts))
        data = f.read(n * step)
    return [struct.unpack_from("<fff", data, i * step) for i in range(n)]


def main():
    main_json = os.path.join(RESULTS, "peers.json")
    entries = json.load(open(main_json))
    sweep_path = os.path.join(RESULTS, "peers_sweep.json")
    sweep = json.load(open(sweep_path)) if os.path.exists(sweep_path) else []
    plots = sweep_plots(entries + sweep)
    workdir = sys.argv[1] if len(sys.argv) > 1 else "/tmp/pcl_ecs_peers"
    picture = edge_picture(workdir, None)
    lines = ["# Results: pcl_ecs against the peers",
             "",
             "Regenerate everything (tables, verdicts, plots) with `bash bench/run_peers.sh` (Release build;",
             "bench/bench_peers.cpp, bench/make_results.py). Every method runs at the same output size: each peer's",
             "own parameter (leaf size, radius, cell size, cluster size) is searched until its size is within 1%",
             "of the target; the count-based ones (RandomSample, NormalSpaceSampling, FarthestPointSampling, WLOP)",
             "are given the target. Each run is timed in a process of its own; peak MiB is the resident memory",
             "above what the loaded input already used. Metrics (`pcl_ecs_eval`), all fractions of L, the",
             "bounding-box diagonal: surface deviation (each original point to the plane of its 8 nearest",
             "simplified points), coverage (each original point to its nearest simplified point), symmetric",
             "Hausdorff, and with the reference mesh the distance from points sampled along its sharp edges",
             "(dihedral above 40°) to the nearest simplified point. Lower is better everywhere.",
             ""]
    lines += ["## The bar, in one table", "",
              "| input | size | sharp edges (lowest; fandisk −30%) | surface deviation (≤ 1.05 × best) | coverage max (≤ 1.5 × best) | faster than hierarchy | faster than WLOP |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for e in entries:
        v = verdict(e)
        def pick(prefix):
            for x in v:
                if x.startswith(prefix):
                    return "met" if ("**met**" in x or "**faster**" in x) else "**no**"
            return "n/a (no reference mesh)"
        lines.append(f"| {e['input']} | {100 * e['ratio']:.0f}% | {pick('sharp-edge')} | {pick('surface')} | {pick('coverage')} | "
                     f"{pick('time against CGAL hierarchy')} | {pick('time against CGAL WLOP')} |")
    lines.append("")
    for e in entries:
        lines += [f"## {e['input']}: {e['points']} points → {100 * e['ratio']:.0f}% ({e['target']})", "", table(e), ""]
        lines += [f"- {v}" for v in verdict(e)] + [""]
    if plots:
        lines += ["## Error against output size", ""] + [f"![{p}]({p})" for p in plots] + [""]
    if picture:
        lines += ["## The fandisk's sharp edges under each method", "", f"![{picture}]({picture})", ""]
    notes = os.path.join(RESULTS, "peers_notes.md")
    if os.path.exists(notes):
        lines += [open(notes).read()]
    open(os.path.join(ROOT, "docs", "RESULTS.md"), "w").write("\n".join(lines) + "\n")
    print("wrote docs/RESULTS.md", plots, picture)


if __name__ == "__main__":
    main()
