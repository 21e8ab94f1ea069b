#!/usr/bin/python3
"""Chung & Ooi test 4 against their published curve (docs/accuracy.md, "Micro-slip"): the tangential restitution e_t
and the spin after impact against the incidence, pflow's wall kernel (micro_slip_test's output) with Chung & Ooi's
alumina DEM curve and Kharaz et al.'s experiment as digitized from their figure. PFLOW.csv is written by
PFLOW_CHUNG_OOI_CSV=PFLOW.csv build/tests/micro_slip_test --gtest_filter='*TheirPublishedCurve' (bench/accuracy/run.sh).
Usage: plot_chung_ooi_test4.py OUT.png PFLOW.csv DIGITIZED.csv"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(path):
    return list(csv.DictReader(line for line in open(path) if not line.startswith("#")))


def main():
    out, ours, ref = sys.argv[1:4]
    p, d = rows(ours), rows(ref)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, q, col, label in ((axes[0], "et", "et_pflow", "tangential restitution e_t = v_t'/v_t"),
                              (axes[1], "spin_rad_per_s", "spin_rad_per_s_pflow", "spin after impact |ω'| [rad/s]")):
        for series, style, name in (("Al_oxide_ref", "-", "Chung & Ooi 2011, alumina DEM (digitized)"),
                                    ("Kharaz2001_experiment", "s", "Kharaz et al. 2001, experiment (as replotted)")):
            pts = [(float(r["incident_angle_deg"]), float(r["value"])) for r in d if r["quantity"] == q and r["series"] == series]
            ax.plot([x for x, _ in pts], [y for _, y in pts], style, color="k", mfc="none", lw=1, label=name)
        ax.plot([float(r["incident_angle_deg"]) for r in p], [float(r[col]) for r in p], "o", color="tab:red", ms=4,
                label="pflow, wall kernel, default step")
        ax.set_xlabel("incidence from the normal [deg]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower right")
    fig.suptitle("Chung & Ooi test 4: alumina sphere, 3.9 m/s, μ = 0.092, e = 0.98", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
