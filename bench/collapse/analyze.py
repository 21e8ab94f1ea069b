#!/usr/bin/env python3
"""Reads the column-collapse sweep's snapshot files (make_scenes.py, run with `pflow run`) and measures each
deposit against the published scalings of the run-out (L_f - L_i)/L_i in the aspect ratio a = H_i/L_i:
Lube et al. 2005 (quasi-2D; sand, rice, sugar): 1.2 a for a < 1.8, 1.9 a^(2/3) for a > 2.8; Lajeunesse et al.
2005 (glass beads): 1.8 a for a < 3, 2.3 a^(2/3) beyond (both as Lagrée, Staron & Popinet 2011, JFM 686, eq. 3.1,
quote them). L_i and H_i are the settled column's at the gate's start; L_f the front of the connected deposit
(particles sorted along x, gaps under 1.5 diameters); H_f the deposit's height.

    analyze.py CSV PNG collapse_a*.h5
"""
import csv
import re
import sys

import h5py
import numpy as np

GATE_X = 0.0201


def lube(a):
    return np.where(a < 1.8, 1.2 * a, np.where(a > 2.8, 1.9 * a ** (2 / 3), np.nan))


def lajeunesse(a):
    return np.where(a < 3.0, 1.8 * a, 2.3 * a ** (2 / 3))


def measure(path):
    with h5py.File(path) as f:
        snaps = sorted(f["snapshots"], key=int)
        settled = f["snapshots"][snaps[1]] if len(snaps) > 1 else f["snapshots"][snaps[0]]
        last = f["snapshots"][snaps[-1]]
        x0, r0 = settled["position"][...], settled["radius"][...]
        x, r, v = last["position"][...], last["radius"][...], last["velocity"][...]
        t_settled, t_end = float(settled.attrs["time"]), float(last.attrs["time"])
    Li = GATE_X
    Hi = float(np.max(x0[:, 2] + r0))
    d = 2 * float(np.max(r))
    order = np.argsort(x[:, 0])
    xs, rs = x[order, 0], r[order]
    last = 0  # the connected deposit's front grain
    for i in range(1, len(xs)):
        if xs[i] - xs[i - 1] > 1.5 * d:
            break
        last = i
    front = float(xs[last] + rs[last])
    Hf = float(np.max(x[:, 2] + r))
    speed = np.linalg.norm(v, axis=1)
    return dict(a=Hi / Li, L_i=Li, H_i=Hi, L_f=front, H_f=Hf, runout=(front - Li) / Li, particles=len(r), d=d, t_settled=t_settled,
                t_end=t_end, v_max=float(np.max(speed)), v_99=float(np.percentile(speed, 99)), ahead=int(len(xs) - 1 - last))


def main():
    out_csv, out_png, files = sys.argv[1], sys.argv[2], sys.argv[3:]
    rows = sorted((measure(p) for p in files), key=lambda r: r["a"])
    for r in rows:
        r["lube"] = float(lube(np.array(r["a"])))
        r["lajeunesse"] = float(lajeunesse(np.array(r["a"])))
    with open(out_csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    for r in rows:
        print("a = %.2f: run-out %.2f (Lajeunesse %.2f: %+.1f %%; Lube %s), H_f/L_i %.2f, %d grains (%d ahead of the front), "
              "v_99 %.4f m/s, v_max %.3f m/s at t = %.2f s" % (
                  r["a"], r["runout"], r["lajeunesse"], 100 * (r["runout"] / r["lajeunesse"] - 1),
                  "%.2f (%+.0f %%)" % (r["lube"], 100 * (r["runout"] / r["lube"] - 1)) if r["lube"] == r["lube"] else "-",
                  r["H_f"] / r["L_i"], r["particles"], r["ahead"], r["v_99"], r["v_max"], r["t_end"]))
    a_ = np.array([r["a"] for r in rows])
    y_ = np.array([r["runout"] for r in rows])
    lin, pw = a_ < 2, a_ > 3  # least squares through the origin, as the experiments' fits
    if lin.any():
        print("linear prefactor (a < 2): %.3f" % (np.sum(a_[lin] * y_[lin]) / np.sum(a_[lin] ** 2)))
    if pw.any():
        print("power-law prefactor (a > 3, exponent 2/3): %.3f" % (np.sum(a_[pw] ** (2 / 3) * y_[pw]) / np.sum(a_[pw] ** (4 / 3))))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    a = np.array([r["a"] for r in rows])
    ro = np.array([r["runout"] for r in rows])
    aa = np.linspace(0.3, max(7, a.max() * 1.1), 200)
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    ax.loglog(a, ro, "o", ms=7, color="C3", label="pflow (DEM, this sweep)")
    ax.loglog(aa[aa < 1.8], 1.2 * aa[aa < 1.8], "-", color="C0", label="Lube et al. 2005: 1.2 a, 1.9 a$^{2/3}$")
    ax.loglog(aa[aa > 2.8], 1.9 * aa[aa > 2.8] ** (2 / 3), "-", color="C0")
    ax.loglog(aa[aa < 3], 1.8 * aa[aa < 3], "--", color="C2", label="Lajeunesse et al. 2005: 1.8 a, 2.3 a$^{2/3}$")
    ax.loglog(aa[aa >= 3], 2.3 * aa[aa >= 3] ** (2 / 3), "--", color="C2")
    ax.set_xlabel("aspect ratio a = H$_i$ / L$_i$")
    ax.set_ylabel("run-out (L$_f$ - L$_i$) / L$_i$")
    ax.set_title("Quasi-2D column collapse: run-out against the published scalings")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_png)


if __name__ == "__main__":
    main()
