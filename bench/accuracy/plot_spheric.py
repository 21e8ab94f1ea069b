#!/usr/bin/python3
"""SPHERIC test 2 (Kleefsman et al. 2005) against pflow's probes (docs/sph.md, "SPHERIC test 2"):
spheric2.png: P1 and P2 pressure, H2 and H4 height over 0.3-0.6 s, from <output>.probes.csv files of
`pflow run examples/dam_break_3d.yaml` at several spacings, with the experiment's first-impact window
(../shared/data/validation/kleefsman_2005_spheric_test2_impact_window.csv).
Usage: plot_spheric.py OUTDIR EXPERIMENT_CSV LABEL=PROBES_CSV [LABEL=PROBES_CSV ...]"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def table(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    head = [h.split(" ")[0] for h in rows[0]]
    return {h: [float(r[i]) for r in rows[1:]] for i, h in enumerate(head)}


def main():
    out, exp_path, runs = sys.argv[1], sys.argv[2], [a.split("=", 1) for a in sys.argv[3:]]
    exp = table(exp_path)
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    for ax, name, unit in zip(axes.flat, ["P1", "P2", "H2", "H4"], ["Pa", "Pa", "m", "m"]):
        for label, path in runs:
            t = table(path)
            pts = [(x, y) for x, y in zip(t["time"], t[name]) if 0.3 <= x <= 0.6]
            ax.plot([p[0] for p in pts], [p[1] for p in pts], lw=1, label="pflow " + label)
        ax.plot(exp["Time"], exp[name], "k.", ms=3, label="Kleefsman et al. 2005 (first-impact window)")
        ax.set_title(name)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(unit)
        if unit == "Pa":
            ax.set_ylim(-2000, 40000)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("SPHERIC test 2: pressure on the box's front face and water heights")
    fig.tight_layout()
    fig.savefig(out + "/spheric2.png", dpi=120)
    print("wrote", out + "/spheric2.png")


if __name__ == "__main__":
    main()
