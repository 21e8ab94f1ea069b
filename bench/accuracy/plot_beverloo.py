#!/usr/bin/python3
"""Beverloo's law from pflow-beverloo's CSVs (docs/accuracy.md, "Beverloo"): the discharge rate W against the orifice
diameter D with each precision's fit W = C rho_b sqrt(g) (D - k d)^{5/2}, and the law with C = 0.58, k = 1.5.
Usage: plot_beverloo.py OUT.png CSV [CSV ...]"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    out, paths = sys.argv[1], sys.argv[2:]
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for path, marker in zip(paths, "os^v"):
        rows = list(csv.DictReader(open(path)))
        D = [float(r["orifice_m"]) for r in rows]
        W = [float(r["flow_rate_kg_per_s"]) for r in rows]
        C, k = float(rows[0]["C_fit"]), float(rows[0]["k_fit"])
        rho = sum(float(r["bulk_density_kg_per_m3"]) for r in rows) / len(rows)
        d = sum(float(r["mean_diameter_m"]) for r in rows) / len(rows)
        label = "%s %s: C = %.3f, k = %.2f" % (rows[0]["executor"], rows[0]["precision"], C, k)
        ax.plot([x * 1e3 for x in D], W, marker, label=label, mfc="none")
        xs = [min(D) * 0.9 + (max(D) * 1.05 - min(D) * 0.9) * i / 50 for i in range(51)]
        ax.plot([x * 1e3 for x in xs], [C * rho * math.sqrt(9.81) * max(x - k * d, 0) ** 2.5 for x in xs], "-", lw=0.8)
        ref = [0.58 * rho * math.sqrt(9.81) * max(x - 1.5 * d, 0) ** 2.5 for x in xs]
    ax.plot([x * 1e3 for x in xs], ref, "k--", lw=0.8, label="Beverloo, C = 0.58, k = 1.5")
    ax.set_xlabel("orifice diameter D [mm]")
    ax.set_ylabel("discharge rate W [kg/s]")
    ax.set_title("Flat-bottomed silo, d = 2 mm, 32 019 beads")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
