#!/usr/bin/python3
"""Janssen's wall-stress profile from pflow-janssen's CSVs (docs/accuracy.md, "Janssen"): the wall's normal stress
against depth with the fitted saturation curve and Janssen's asymptote rho_b g D / (4 mu) for the mobilised friction.
Usage: plot_janssen.py OUT.png CSV [CSV ...]"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    out, paths = sys.argv[1], sys.argv[2:]
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for path, marker in zip(paths, "os"):
        rows = list(csv.DictReader(open(path)))
        z = [float(r["depth_m"]) for r in rows]
        s = [float(r["wall_normal_stress_pa"]) for r in rows]
        t = [float(r["wall_shear_stress_pa"]) for r in rows]
        sinf, lam, jinf, K = (float(rows[0][k]) for k in ("sigma_inf_fit_pa", "lambda_m", "janssen_sigma_inf_pa", "K"))
        tag = "float" if "float" in path else "double"
        ax.plot([x * 1e3 for x in z], s, marker, mfc="none", label="σ_w, %s (fit: σ∞ %.0f Pa, λ %.0f mm, K %.2f)" % (tag, sinf, lam * 1e3, K))
        ax.plot([x * 1e3 for x in z], t, marker, ms=4, label="τ_w, %s" % tag)
        zs = [max(z) * 1.1 * i / 60 for i in range(61)]
        ax.plot([x * 1e3 for x in zs], [sinf * (1 - math.exp(-x / lam)) for x in zs], "-", lw=0.8)
        ax.axhline(jinf, ls="--", lw=0.8, color="k")
    ax.text(2, jinf * 1.02, "ρ_b g D / (4 μ_mobilised)", fontsize=8)
    ax.set_xlabel("depth below the surface [mm]")
    ax.set_ylabel("wall stress [Pa]")
    ax.set_title("Silo D = 40 mm, 42 749 beads (d = 2 mm)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
