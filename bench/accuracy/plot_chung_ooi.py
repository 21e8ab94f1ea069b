#!/usr/bin/python3
"""Chung & Ooi tests 4 and 6 against their published curves (docs/accuracy.md, "Micro-slip"): pflow's wall kernel
(micro_slip_test's tables) with Chung & Ooi's curves as digitized from their figures.
  test 4: the tangential restitution e_t and the spin after impact against the incidence (alumina), with Kharaz et
          al.'s experiment as they replot it;
  test 6: beta = -u'/u of the contact point against 3.5 mu (1 + e) v_n / u, and the tangent of the recoil angle
          against that of the incidence (aluminium alloy and nylon spinning spheres).
The tables are written by PFLOW_CHUNG_OOI_DIR=DIR build/tests/micro_slip_test --gtest_filter='*TheirPublishedCurve'
(bench/accuracy/run.sh). Usage: plot_chung_ooi.py DIR SOURCE_DIR (writes DIR/chung_ooi_test4.png, _test6.png)"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(path):
    return list(csv.DictReader(line for line in open(path) if not line.startswith("#")))


def curve(d, quantity, series, xcol):
    pts = [(float(r[xcol]), float(r["value"])) for r in d if r["quantity"] == quantity and r["series"] == series]
    return [x for x, _ in pts], [y for _, y in pts]


def test4(out, p, d):
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, q, col, label in ((axes[0], "et", "et_pflow", "tangential restitution e_t = v_t'/v_t"),
                              (axes[1], "spin_rad_per_s", "spin_rad_per_s_pflow", "spin after impact |ω'| [rad/s]")):
        for series, style, name in (("Al_oxide_ref", "-", "Chung & Ooi 2011, alumina DEM (digitized)"),
                                    ("Kharaz2001_experiment", "s", "Kharaz et al. 2001, experiment (as replotted)")):
            ax.plot(*curve(d, q, series, "incident_angle_deg"), style, color="k", mfc="none", lw=1, label=name)
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


def test6(out, p, d):
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for series, color, name in (("Al_alloy_ref", "tab:red", "aluminium alloy"), ("nylon_ref", "tab:blue", "nylon")):
        ours = [r for r in p if r["series"] == series]
        x = [float(r["x"]) for r in ours]
        axes[0].plot(*curve(d, "beta", series, "x"), "-", color=color, lw=1, label=f"Chung & Ooi 2011, {name} (digitized)")
        axes[0].plot(x, [float(r["beta_pflow"]) for r in ours], "o", color=color, mfc="none", ms=4, label=f"pflow, {name}")
        tan_in = [3.5 * 0.4 * 1.5 / v for v in x]
        axes[1].plot(*curve(d, "tan_recoil", series, "x"), "-", color=color, lw=1, label=f"Chung & Ooi 2011, {name}")
        axes[1].plot(tan_in, [float(r["tan_recoil_pflow"]) for r in ours], "o", color=color, mfc="none", ms=4,
                     label=f"pflow, {name}")
    axes[0].set_xscale("log")
    axes[0].set_xlabel("3.5 μ (1 + e) v_n / u")
    axes[0].set_ylabel("β = −u'/u (contact point)")
    axes[1].set_xlabel("tan of incidence u / v_n")
    axes[1].set_ylabel("tan of recoil u' / v_n'")
    axes[1].set_xlim(0, 6.5)
    axes[1].set_ylim(-1, 8.5)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5)
    fig.suptitle("Chung & Ooi test 6: spinning spheres, R = 0.1 m, v_n = 0.2 m/s, μ = 0.4, e = 0.5", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


def main():
    out, src = sys.argv[1:3]
    for n, draw in (("4", test4), ("6", test6)):
        table = os.path.join(out, f"chung_ooi_test{n}_pflow.csv")
        if os.path.exists(table):
            draw(os.path.join(out, f"chung_ooi_test{n}.png"), rows(table),
                 rows(os.path.join(src, "docs", "accuracy", f"chung_ooi_2011_test{n}_digitized.csv")))


if __name__ == "__main__":
    main()
