#!/usr/bin/python3
"""SPHERIC test 2 (Kleefsman et al. 2005) against pflow's probes (docs/sph.md, "SPHERIC test 2"):
spheric2.png: P1 and P2 pressure over 0.35-0.6 s, the heights at x = 0.992 (H2), 1.488 (H3) and 2.638 m (H4) over
0-1 s, and the reservoir's lag (the delay after which a run's H4 has fallen as far as the experiment's), from
<output>.probes.csv files of `pflow run examples/dam_break_3d.yaml`, against the experiment's record over 0-1 s
(bench/accuracy/data/kleefsman_2005_spheric_test2_0-1s.csv). The record's columns H1 and H3 are read swapped
(docs/sph.md): its H1 wets at 0.19 s, so it is the gauge 0.50 m from the gate (x = 1.488, our H3), and its H3 at
0.92 s, behind the box (x = 0.496).
spheric2_top.png: P5-P8 on the box's top (0.021-0.141 m behind its front edge) over 0.3-1 s, for the runs whose
files have them (the example has had them since 2026-12-02).
Also prints, for each run, the first time P1 and P2 pass 500 Pa and the reservoir's lag at 0.1-0.4 s, and for P5-P8
the first time each passes 500 Pa and its largest reading over the record's 0-1 s.
Usage: plot_spheric.py OUTDIR EXPERIMENT_CSV LABEL=PROBES_CSV [LABEL=PROBES_CSV ...]"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LAG_TIMES = [0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4]


def table(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    head = [h.split(" ")[0] for h in rows[0]]
    return {h: [float(r[i]) for r in rows[1:]] for i, h in enumerate(head)}


def at(t, y, x):
    for k in range(len(t) - 1):
        if t[k] <= x <= t[k + 1]:
            w = (x - t[k]) / (t[k + 1] - t[k])
            return y[k] * (1 - w) + y[k + 1] * w
    return float("nan")


def first_above(t, y, threshold=500.0):
    return next((a for a, b in zip(t, y) if b > threshold), float("nan"))


def reservoir_lag(exp, run):
    """At each time of LAG_TIMES: how much later the run's H4 has fallen as far below its start as the
    experiment's below its mean over the first 40 ms (the record's H4 rings by +-4 mm then)."""
    e0 = sum(exp["H4"][:40]) / 40
    r0 = run["H4"][0]
    lags = []
    for x in LAG_TIMES:
        drop = e0 - at(exp["Time"], exp["H4"], x)
        t, h = run["time"], run["H4"]
        lag = float("nan")
        for k in range(len(t) - 1):
            a, b = r0 - h[k], r0 - h[k + 1]
            if a <= drop < b:
                lag = t[k] + (t[k + 1] - t[k]) * (drop - a) / (b - a) - x
                break
        lags.append(lag)
    return lags


def main():
    out, exp_path, runs = sys.argv[1], sys.argv[2], [a.split("=", 1) for a in sys.argv[3:]]
    exp = table(exp_path)
    exp_gauge = {"H2": "H2", "H3": "H1", "H4": "H4"}  # our gauge -> the record's column (H1/H3 swapped)
    data = [(label, table(path)) for label, path in runs]
    fig, axes = plt.subplots(2, 3, figsize=(15, 8))
    panels = [("P1", "Pa", 0.35, 0.6), ("P2", "Pa", 0.35, 0.6), ("lag", "s", 0, 0),
              ("H2", "m", 0, 1), ("H3", "m", 0, 1), ("H4", "m", 0, 1)]
    print("run  P1>500Pa  P2>500Pa  reservoir lag [ms] at " + " ".join("%.2f" % x for x in LAG_TIMES))
    print("experiment  %.4f  %.4f" % (first_above(exp["Time"], exp["P1"]), first_above(exp["Time"], exp["P2"])))
    for label, t in data:
        lags = reservoir_lag(exp, t)
        print("%s  %.4f  %.4f  %s" % (label, first_above(t["time"], t["P1"]), first_above(t["time"], t["P2"]),
                                      " ".join("%+.0f" % (1000 * x) for x in lags)))
    for ax, (name, unit, lo, hi) in zip(axes.flat, panels):
        if name == "lag":
            for label, t in data:
                ax.plot(LAG_TIMES, [1000 * x for x in reservoir_lag(exp, t)], "o-", ms=3, lw=1, label="pflow " + label)
            ax.set_title("H4: how much later a run has drained as far")
            ax.set_xlabel("t [s]")
            ax.set_ylabel("lag [ms]")
            ax.axhline(0, color="k", lw=0.5)
        else:
            for label, t in data:
                pts = [(x, y) for x, y in zip(t["time"], t[name]) if lo <= x <= hi]
                ax.plot([p[0] for p in pts], [p[1] for p in pts], lw=1, label="pflow " + label)
            col = exp_gauge.get(name, name)
            pts = [(x, y) for x, y in zip(exp["Time"], exp[col]) if lo <= x <= hi]
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "k-", lw=0.8,
                    label="Kleefsman et al. 2005" + ("" if col == name else " (record's %s)" % col))
            where = {"P1": "box face, z = 0.021 m", "P2": "box face, z = 0.061 m", "H2": "x = 0.992 m",
                     "H3": "x = 1.488 m", "H4": "x = 2.638 m"}[name]
            ax.set_title("%s (%s)" % (name, where))
            ax.set_xlabel("t [s]")
            ax.set_ylabel(unit)
            if unit == "Pa":
                ax.set_ylim(-2000, 40000)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("SPHERIC test 2: pressure on the box's front face, water heights, and the reservoir's lag")
    fig.tight_layout()
    fig.savefig(out + "/spheric2.png", dpi=110)
    print("wrote", out + "/spheric2.png")
    top(out, exp, [(label, t) for label, t in data if "P5" in t])


TOP = [("P5", 0.021), ("P6", 0.061), ("P7", 0.101), ("P8", 0.141)]  # name, distance behind the front edge [m]


def top(out, exp, data):
    """The box's top: the record reads under 0.1 kPa there through its first second (the water that runs up the front
    face does not fall on the sensors); where a run reads more, the chart and the table show how much and when."""
    print("top   " + "  ".join("%s>500Pa  %s max [Pa]" % (n, n) for n, _ in TOP))
    for label, t in [("experiment", {"time": exp["Time"], **exp})] + data:
        cells = []
        for name, _ in TOP:
            pts = [(x, y) for x, y in zip(t["time"], t[name]) if x < 1.0]
            first = first_above([p[0] for p in pts], [p[1] for p in pts])
            peak = max(pts, key=lambda p: p[1])
            cells.append("%.4f  %.0f (%.3f s)" % (first, peak[1], peak[0]))
        print("%s  %s" % (label, "  ".join(cells)))
    if not data:
        return
    fig, axes = plt.subplots(1, 4, figsize=(18, 4))
    for ax, (name, back) in zip(axes, TOP):
        for label, t in data:
            pts = [(x, y) for x, y in zip(t["time"], t[name]) if 0.3 <= x <= 1.0]
            ax.plot([p[0] for p in pts], [p[1] for p in pts], lw=1, label="pflow " + label)
        pts = [(x, y) for x, y in zip(exp["Time"], exp[name]) if 0.3 <= x <= 1.0]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "k-", lw=0.8, label="Kleefsman et al. 2005")
        ax.set_title("%s (box top, %.3f m behind the front edge)" % (name, back))
        ax.set_xlabel("t [s]")
        ax.set_ylabel("Pa")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("SPHERIC test 2: pressure on the box's top")
    fig.tight_layout()
    fig.savefig(out + "/spheric2_top.png", dpi=110)
    print("wrote", out + "/spheric2_top.png")


if __name__ == "__main__":
    main()
