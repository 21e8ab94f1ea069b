#!/usr/bin/python3
"""The poured piles' surfaces from pflow-repose's CSVs (docs/accuracy.md, "Angle of repose"): the highest bead top
in each ring against the distance from the axis, the line fitted between 25 % and 75 % of the heap's radius, and the
slope of the measured angle (Sunday et al. 2020: 25.2 +- 0.8 degrees) through the fit's middle.
Usage: plot_repose.py OUT.png ROWS.csv PROFILES.csv"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MEASURED, SPREAD = 25.2, 0.8


def run_key(r):
    """A run's rolling coefficients, floor, pour height [mm], precision and plate half-width [mm]: what tells the runs
    of one CSV apart, and joins a row to its surface."""
    return (r["rolling"], r["wall_rolling"], r["floor"], round(float(r["pour_height_m"]) * 1e3, 3), r["precision"],
            round(float(r["plate_half_width_m"]) * 1e3, 3))


def label(key, angle, usual):
    """The legend's line: what sets the run apart from the usual pour (40 mm, float, the most common plate)."""
    rolling, wall, floor, height, precision, plate = key
    more = [", bead floor" if floor == "beads" else "", "" if height == 40 else ", poured from %g mm" % height,
            "" if precision == "float" else ", " + precision, "" if plate == usual else ", %g mm plate" % (2 * plate)]
    return "μr %s / %s%s: %.1f°" % (rolling, wall, "".join(more), angle)


def main():
    out, rows_path, profiles_path = sys.argv[1:4]
    rows = list(csv.DictReader(open(rows_path)))
    profiles = list(csv.DictReader(open(profiles_path)))
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    plates = [run_key(r)[5] for r in rows]
    usual = max(set(plates), key=plates.count)
    colours = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:olive")
    for row, colour in zip(rows, colours):
        key = run_key(row)
        pts = [(float(p["radius_m"]), float(p["height_m"])) for p in profiles if run_key(p) == key]
        radius, lo, hi = float(row["heap_radius_m"]), float(row["fit_from_m"]), float(row["fit_to_m"])
        pts = [(r, h) for r, h in pts if r <= 1.3 * radius and h > -0.002]
        ax.plot([r * 1e3 for r, _ in pts], [h * 1e3 for _, h in pts], ".", ms=3, color=colour,
                label=label(key, float(row["angle_deg"]), usual))
        fit = [(r, h) for r, h in pts if lo <= r <= hi]
        n = len(fit)
        sx, sy = sum(r for r, _ in fit), sum(h for _, h in fit)
        sxx, sxy = sum(r * r for r, _ in fit), sum(r * h for r, h in fit)
        slope = (n * sxy - sx * sy) / (n * sxx - sx * sx)
        b = (sy - slope * sx) / n
        ax.plot([lo * 1e3, hi * 1e3], [(b + slope * lo) * 1e3, (b + slope * hi) * 1e3], "-", color=colour, lw=1.5)
        mid = 0.5 * (lo + hi)
        hm = b + slope * mid
        for deg, style in ((MEASURED, "--"), (MEASURED - SPREAD, ":"), (MEASURED + SPREAD, ":")):
            t = math.tan(math.radians(deg))
            ax.plot([lo * 1e3, hi * 1e3], [(hm + t * (mid - lo)) * 1e3, (hm - t * (hi - mid)) * 1e3], style, color="k", lw=0.7)
    ax.plot([], [], "--", color="k", lw=0.7, label="measured 25.2 ± 0.8° (Sunday et al. 2020)")
    ax.set_xlabel("distance from the axis [mm]")
    ax.set_ylabel("highest bead top [mm]")
    ax.set_title("Poured pile, 58 040 glass beads (d 0.8–1.2 mm); float unless marked")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
