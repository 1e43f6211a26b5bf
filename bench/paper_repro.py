#!/usr/bin/env python3
"""docs/PAPER.md: the paper's experiments rerun on the shared scans, beside its published numbers.

Fig. 3: feature points on the bunny for alpha = 4.5, 3.5, 2.5. Fig. 8: output sizes and
simplification rates for T_err = 1e-5, 1e-6, 1e-7 with the paper's error form. Fig. 10: time of
preprocessing, simplification and Cocone reconstruction. Runs the built tools (standard library
only): python3 bench/paper_repro.py [BUILD_DIR] [DATA_DIR]
"""
import json
import os
import platform
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BUILD = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build")
DATA = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "..", "shared", "data")
SIMPLIFY = os.path.join(BUILD, "tools", "pcd_simplify")
RECONSTRUCT = os.path.join(BUILD, "tools", "pcd_reconstruct")


def simplify(src, args, tmp, mesh=False):
    out = os.path.join(tmp, "out.pcd")
    stats = os.path.join(tmp, "stats.json")
    # The paper's method: without the gap bound (--max-gap 0), which is ours.
    cmd = [SIMPLIFY, src, out, "--stats", stats, "--quiet", "--max-gap", "0"] + args
    subprocess.run(cmd, check=True)
    s = json.load(open(stats))
    if mesh:
        mstats = os.path.join(tmp, "mesh.json")
        subprocess.run([RECONSTRUCT, out, os.path.join(tmp, "mesh.ply"), "--stats", mstats, "--quiet"], check=True)
        s["mesh"] = json.load(open(mstats))
    return s


def main():
    lines = ["# The paper's experiments, reproduced", "",
             f"Regenerate with `python3 bench/paper_repro.py` (Release build). Machine: {os.cpu_count()} cores, "
             f"{platform.machine()}; the paper's: a Pentium 4 at 2.99 GHz with 2 GB. Every run is the paper's "
             "method: `--max-gap 0` (our gap bound, `docs/RESULTS.md`, off).", ""]
    with tempfile.TemporaryDirectory() as tmp:
        # Fig. 3
        bunny = os.path.join(DATA, "bunny.pcd")
        paper = {4.5: 278, 3.5: 702, 2.5: 1086}
        lines += ["## Fig. 3: feature points on the bunny for three α", "",
                  "| α | paper (35,292 points) | paper % | ours (35,947 points) | ours % |", "| --- | --- | --- | --- | --- |"]
        ours = {}
        for a in (4.5, 3.5, 2.5):
            s = simplify(bunny, ["--alpha", str(a)], tmp)
            f = s["counts"]["feature_points"]
            ours[a] = f
            lines.append(f"| {a} | {paper[a]} | {100 * paper[a] / 35292:.2f}% | {f} | {100 * f / s['counts']['finite_points']:.2f}% |")
        fewer = [a for a in ours if ours[a] < paper[a]]
        lines += ["", f"Both fall as α grows. Our count changes faster with α: from α = 4.5 to 2.5 it is multiplied by "
                  f"{ours[2.5] / max(ours[4.5], 1):.1f}, the paper's by {paper[2.5] / paper[4.5]:.1f}; ours is below the "
                  f"paper's at α = {', '.join(str(a) for a in sorted(fewer)) or 'none'}. The measure (eq. 3) is a sum over the "
                  "k nearest neighbours and the paper does not give k for this figure (we use K = 16, with PCA normals of "
                  "the same neighbours), and its bunny has 655 points fewer than the shared one: the tail of the measure's "
                  "distribution, which α cuts, depends on both.", ""]

        # Fig. 8
        paper8 = [("Head", 146773, [102425, 42807, 5578]), ("Kitten", 137098, [97204, 32773, 4215]),
                  ("Armadillo", 165954, [132018, 77762, 8701])]
        lines += ["## Fig. 8: output size and simplification rate against T_err (paper error form)", "",
                  "The paper's models (Head, Kitten, Armadillo) are not in the shared data; its table is given first, "
                  "ours on the shared scans after. Rate = 1 − output / input.", "",
                  "| model | input | T_err 1e-7 | 1e-6 | 1e-5 |", "| --- | --- | --- | --- | --- |"]
        for name, n, outs in paper8:
            cells = " | ".join(f"{o} ({100 * (1 - o / n):.0f}%)" for o in outs)
            lines.append(f"| {name} (paper) | {n} | {cells} |")
        timing_rows = []
        for name, f in (("bunny", "bunny.pcd"), ("fandisk", "fandisk_scan.pcd"), ("bun000 range scan", "bun000_rangescan.pcd")):
            cells = []
            for terr in ("1e-7", "1e-6", "1e-5"):
                s = simplify(os.path.join(DATA, f), ["--error-form", "paper", "--terr", terr], tmp, mesh=True)
                n = s["counts"]["finite_points"]
                o = s["counts"]["output_points"]
                cells.append(f"{o} ({100 * (1 - o / n):.0f}%)")
                t = s["timings_s"]
                pre = t["neighbors"] + t["normals"] + t["weights"] + t["features"] + t["density"] + t["curvature"] + t["preparation"]
                timing_rows.append((name, terr, pre, t["cover"], s["mesh"]["timings_s"]["total"], n, o))
            lines.append(f"| {name} (ours) | {n} | {' | '.join(cells)} |")
        lines += ["", "The trend is the paper's: the rate falls as T_err falls. The numbers are not: at the same T_err our "
                  "paper-form runs keep more points than the paper's models (table). The paper's E(r) = √Q / L (eq. 14) is "
                  "not scale-free: Q sums w_j G(·)(n_j·(x − p_j))² over the ball, so it grows with the number of points in "
                  "the ball, with the weights w_j of eq. 1 (whose scale the paper leaves open) and with noise. On the "
                  "fandisk (Gaussian noise 2·10⁻⁴ L) the smallest balls already exceed 10⁻⁶, so at 10⁻⁶ and 10⁻⁷ almost "
                  "every point is its own ball; on the denser bun000 view the same T_err removes more. Our default "
                  "`normalized` form divides Q by the total weight, which makes T_err a distance in units of L whatever "
                  "the density (SPEC_NOTES).", ""]

        # Fig. 10
        lines += ["## Fig. 10: time per stage", "",
                  "Paper (Pentium 4), seconds: preprocessing 2.2-2.8; simplification 3.4-5.2 at T_err 1e-5, 9.7-19.5 at "
                  "1e-6, 23.9-33.3 at 1e-7; Cocone reconstruction 2.2-5.0 at 1e-5, 22-57 at 1e-6, 72-104 at 1e-7 "
                  "(models of 137k-166k points).", "",
                  "| ours | T_err | preprocessing s | simplification s | Cocone s | input | output |",
                  "| --- | --- | --- | --- | --- | --- | --- |"]
        for name, terr, pre, cover, rec, n, o in timing_rows:
            lines.append(f"| {name} | {terr} | {pre:.3f} | {cover:.3f} | {rec:.3f} | {n} | {o} |")
        b = {terr: (cover, rec) for name, terr, pre, cover, rec, n, o in timing_rows if name == "bunny"}
        lines += ["", "Preprocessing is neighbours, normals, weights, feature measure, density and curvature; "
                  "simplification is the ball cover; Cocone is `pcd_reconstruct` on the output. Reconstruction time "
                  "follows the output size, as in the paper. From T_err 1e-5 to 1e-7 our simplification of the bunny "
                  f"takes ×{b['1e-7'][0] / b['1e-5'][0]:.1f} the time ({b['1e-5'][0]:.3f} → {b['1e-7'][0]:.3f} s); the paper's "
                  "takes ×6.4-7.1. Below the noise and sampling scale a ball's error exceeds T_err at the smallest "
                  "radius, the solve stops at once and the ball keeps its centre alone, so small T_err costs little "
                  "here. Absolute times cannot be compared across a Pentium 4 and today's machine.", ""]
    open(os.path.join(ROOT, "docs", "PAPER.md"), "w").write("\n".join(lines) + "\n")
    print("wrote docs/PAPER.md")


if __name__ == "__main__":
    main()
