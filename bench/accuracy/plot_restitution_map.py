#!/usr/bin/python3
"""The realised restitution's signed error against the requested e and the time step (docs/accuracy.md,
"Restitution at the working time step"): a map per material from the restitution rows of study.csv (sphere on a
rigid plane, double, E/1, CPU). Writes docs/accuracy/restitution_map.png and prints the table.
    plot_restitution_map.py [STUDY_DIR]"""
import csv
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "../../docs/accuracy")
rows = [r for r in csv.DictReader(open(os.path.join(out, "study.csv")))
        if r["problem"].startswith("restitution/") and r["executor"] == "cpu" and r["precision"] == "double"
        and r["softening"] == "1" and r["status"] == "ok" and r["skin_fraction"] == "0.1" and r["rebuild_interval"] == "0"]
materials = sorted({r["problem"].split("/")[1].rsplit("_e", 1)[0] for r in rows})
es = sorted({float(r["reference"]) for r in rows})
dts = sorted({float(r["dt_fraction"]) for r in rows})
fig, axes = plt.subplots(1, len(materials), figsize=(6.5 * len(materials), 4.2), squeeze=False)
for ax, mat in zip(axes[0], materials):
    grid = np.full((len(es), len(dts)), np.nan)
    for r in rows:
        if r["problem"].split("/")[1].rsplit("_e", 1)[0] != mat:
            continue
        e, dt = float(r["reference"]), float(r["dt_fraction"])
        grid[es.index(e), dts.index(dt)] = 100 * (float(r["value"]) / e - 1)
    lim = np.nanmax(np.abs(grid[:, [i for i, d in enumerate(dts) if d <= 0.5]]))
    im = ax.imshow(grid, cmap="RdBu_r", vmin=-lim, vmax=lim, aspect="auto", origin="lower")
    for i in range(len(es)):
        for j in range(len(dts)):
            if np.isfinite(grid[i, j]):
                ax.text(j, i, "%.1f" % grid[i, j], ha="center", va="center", fontsize=7,
                        color="k" if abs(grid[i, j]) < 0.6 * lim else "w")
    ax.set_xticks(range(len(dts)), ["%g" % d for d in dts])
    ax.set_yticks(range(len(es)), ["%g" % e for e in es])
    ax.set_xlabel("dt / Rayleigh time")
    ax.set_ylabel("requested restitution e")
    ax.set_title("%s on a rigid plane: realised e, error %%" % mat.replace("_", " "))
    fig.colorbar(im, ax=ax, label="realised / requested - 1 (%)")
    print(mat, "dt:", " ".join("%6g" % d for d in dts))
    for i, e in enumerate(es):
        print("  e %.1f" % e, " ".join("%6.2f" % v for v in grid[i]))
fig.tight_layout()
fig.savefig(os.path.join(out, "restitution_map.png"), dpi=110)
print("wrote", os.path.join(out, "restitution_map.png"))
