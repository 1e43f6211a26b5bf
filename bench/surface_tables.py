#!/usr/bin/env python3
"""The tables of docs/SURFACE.md from bench/run_surface.sh's JSON files.

    python3 bench/surface_tables.py bench/results/surface.json bench/results/surface_closed.json
"""
import json
import sys

SHORT = {"Cocone (pcl_ecs)": "**Cocone**", "PCL GreedyProjection": "GreedyProjection",
         "PCL Poisson (depth 8)": "Poisson", "CGAL Advancing Front": "Advancing Front"}


def e(x):
    return f"{x:.1e}".replace("e-0", "e-").replace("e+0", "e")


def first(path):
    print("| input | method | time s | non-manifold edges | boundary loops | components | mean | Hausdorff |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for entry in json.load(open(path)):
        name = f"{entry['input']}, {entry['points']:,} pts"
        for k, m in enumerate(entry["methods"]):
            print(f"| {name if k == 0 else ''} | {SHORT.get(m['method'], m['method'])} | {m['seconds']:.3f} | "
                  f"{m['nonmanifold_edges']} | {m['boundary_loops']} | {m['components']} | "
                  f"{e(m.get('to_reference_mean', 0))} | {e(m.get('hausdorff', 0))} |")
    print()
    for entry in json.load(open(path)):
        c = entry["methods"][0]
        print(f"- {entry['input']}: Cocone {c['seconds']:.3f} s, Delaunay alone {entry['delaunay_alone_s']:.3f} s "
              f"({c['seconds'] / entry['delaunay_alone_s']:.2f}×)")


def closed(path):
    rows = json.load(open(path))
    print("| input | kept | points | Cocone boundary edges | AF boundary edges | Cocone χ | AF χ | reference χ | "
          "Cocone components | mean dist Cocone ÷ AF | time Cocone ÷ AF | bar |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    met = {k: 0 for k in ("manifold", "boundary", "euler", "distance", "time")}
    closed_refs = 0
    for r in rows:
        c, a = r["methods"][0], r["methods"][1]
        share = lambda m: f"{100.0 * m['boundary_edges'] / max(1, m['edges']):.2f}%"
        bar = r["bar"]
        failed = [k for k in ("boundary", "euler", "distance", "time") if not bar[k] and (k != "euler" or r["reference_closed"])]
        if not bar["manifold"]:
            failed.insert(0, "manifold")
        for k in met:
            met[k] += 1 if bar[k] and (k != "euler" or r["reference_closed"]) else 0
        closed_refs += 1 if r["reference_closed"] else 0
        ref = f"{r['reference_euler']}" + ("" if r["reference_closed"] else " (open)")
        print(f"| {r['input']} | {round(100 * r['kept'])}% | {r['points']:,} | {share(c)} | {share(a)} | {c['euler']} | "
              f"{a['euler']} | {ref} | {c['components']} | "
              f"{c['to_reference_mean'] / a['to_reference_mean']:.2f} | {c['seconds'] / a['seconds']:.2f} | "
              f"{'met' if not failed else 'not: ' + ', '.join(failed)} |")
    n = len(rows)
    print()
    print(f"Of {n} runs, Cocone is manifold on {met['manifold']}, has at most 0.2% boundary edges on "
          f"{met['boundary']}, the reference's Euler characteristic on {met['euler']} of the {closed_refs} with a "
          f"closed reference, a mean distance at most Advancing Front's on {met['distance']} and a time at most "
          f"its on {met['time']}.")


if __name__ == "__main__":
    first(sys.argv[1])
    print()
    closed(sys.argv[2])
