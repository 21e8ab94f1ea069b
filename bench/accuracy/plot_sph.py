#!/usr/bin/python3
"""Charts of the SPH dam-break study (docs/sph.md, "Convergence") from pflow-accuracy --solver sph output:
  dam_break_2d.png     surge front Z = x/a against T = t sqrt(2g/a) for every resolution, with Martin & Moyce
                       (1952, both column widths) and Koshizuka & Oka's replot; dashed: mirror walls
                       (DIR/dam_break_2d_mirror.csv, when there);
  convergence.png      left: RMS relative error of the front times against cost (wall s per simulated s), one
                       point per run, by sweep; right: |T - T_finest| at Z = 2.5 against dp, with the observed order.
Usage: plot_sph.py DIR [VALIDATION_DIR]  (reads DIR/dam_break_2d.csv and DIR/convergence.csv, writes the PNGs
there; VALIDATION_DIR holds martin_moyce_1952_pysph.csv, default ../shared/data/validation)."""
import csv
import math
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def fnum(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return math.nan


def experiment(vdir):
    series = defaultdict(list)
    path = os.path.join(vdir, "martin_moyce_1952_pysph.csv")
    if os.path.exists(path):
        for r in rows(path):
            series["Martin & Moyce " + r["series"].replace("a=", "a = ")].append((fnum(r["T"]), fnum(r["Z"])))
    return series


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "docs/sph"
    here = os.path.dirname(os.path.abspath(__file__))
    vdir = sys.argv[2] if len(sys.argv) > 2 else os.path.join(here, "..", "..", "..", "shared", "data", "validation")
    curves = defaultdict(list)
    for r in rows(os.path.join(out, "dam_break_2d.csv")):
        curves[r["resolution"]].append((fnum(r["T"]), fnum(r["Z"])))
    fig, ax = plt.subplots(figsize=(7, 5))
    colours = {}
    for name, pts in sorted(curves.items(), key=lambda kv: int(kv[0].split("x")[0])):
        line = ax.plot([p[0] for p in pts], [p[1] for p in pts], label="pflow SPH " + name, lw=1.4)[0]
        colours[name] = line.get_color()
    mirror_path = os.path.join(out, "dam_break_2d_mirror.csv")
    if os.path.exists(mirror_path):
        mirror = defaultdict(list)
        for r in rows(mirror_path):
            mirror[r["resolution"]].append((fnum(r["T"]), fnum(r["Z"])))
        for name, pts in sorted(mirror.items(), key=lambda kv: int(kv[0].split("x")[0])):
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "--", color=colours.get(name), label="mirror walls " + name, lw=1.1)
    for (name, pts), marker in zip(sorted(experiment(vdir).items()), "os^"):
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker, mfc="none", color="k", label=name)
    ax.set_xlim(0, 3.5)
    ax.set_ylim(1, 4.2)
    ax.set_xlabel("T = t sqrt(2g/a)")
    ax.set_ylabel("Z = x/a (surge front)")
    ax.set_title("2D dam break, a = 0.2 m, H = 2a: pflow WCSPH against the experiment")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "dam_break_2d.png"), dpi=130)

    conv = rows(os.path.join(out, "convergence.csv"))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 5))
    groups = defaultdict(list)
    for r in conv:
        groups[(r["sweep"], r["executor"], r["precision"])].append(r)
    for (sweep, ex, prec), rs in sorted(groups.items()):
        ok = [r for r in rs if r["status"] == "ok" and not math.isnan(fnum(r["rms_rel_err"]))]
        bad = [r for r in rs if r["status"] != "ok"]
        label = "%s (%s, %s)" % (sweep, ex, prec)
        line = a1.plot([fnum(r["wall_per_sim_s"]) for r in ok], [fnum(r["rms_rel_err"]) for r in ok], "o-", label=label)[0]
        for r in ok:
            a1.annotate(r["resolution"] + ("" if fnum(r["dt"]) == 0 else " dt %g" % fnum(r["dt"])),
                        (fnum(r["wall_per_sim_s"]), fnum(r["rms_rel_err"])), fontsize=6)
        for r in bad:
            a1.plot([fnum(r["wall_per_sim_s"]) or 1e-3], [1.0], "x", color=line.get_color(), ms=9)
            a1.annotate(r["resolution"] + " dt %g: %s" % (fnum(r["dt"]), r["status"]), (fnum(r["wall_per_sim_s"]) or 1e-3, 1.0), fontsize=6)
    a1.set_xscale("log")
    a1.set_yscale("log")
    a1.set_xlabel("cost: wall s per simulated s")
    a1.set_ylabel("RMS relative error of T(Z = 1.5 .. 3.5) against Martin & Moyce")
    a1.grid(alpha=0.3, which="both")
    a1.legend(fontsize=7)
    # Self-convergence at Z = 2.5 along the resolution ladder: |T - T_finest| against dp.
    for (sweep, ex, prec), rs in sorted(groups.items()):
        if sweep != "resolution":
            continue
        rs = sorted((r for r in rs if r["status"] == "ok"), key=lambda r: fnum(r["dp"]))
        if len(rs) < 3:
            continue
        finest = fnum(rs[0]["T_2.5"])
        pts = [(fnum(r["dp"]), abs(fnum(r["T_2.5"]) - finest)) for r in rs[1:]]
        a2.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label="%s, %s" % (ex, prec))
        if len(pts) >= 2 and pts[0][1] > 0 and pts[-1][1] > 0:
            order = math.log(pts[-1][1] / pts[0][1]) / math.log(pts[-1][0] / pts[0][0])
            a2.annotate("observed order %.2f" % order, pts[-1], fontsize=8)
    a2.set_xlabel("dp [m] (h = 1.5 dp)")
    a2.set_ylabel("|T(Z=2.5) - T at the finest dp|")
    a2.grid(alpha=0.3, which="both")
    a2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "convergence.png"), dpi=130)
    print("wrote", os.path.join(out, "dam_break_2d.png"), "and", os.path.join(out, "convergence.png"))


if __name__ == "__main__":
    main()
