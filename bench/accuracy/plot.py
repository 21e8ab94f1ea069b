#!/usr/bin/python3
"""Charts of the accuracy-speed study (docs/accuracy.md) from study.csv: per problem family and executor,
  <family>_<executor>_cost.png  error against cost (wall s per simulated s), log-log, Pareto front marked;
  <family>_<executor>_dt.png    error against the dt fraction of the Rayleigh time, failures marked.
The reference run of a problem without a closed form (error 0) is not drawn.
Variants of a family (glass and limestone; every e of the restitution problem) are combined per setting:
the worst error and the largest cost over the variants, and a run counts as failed if any variant failed.
Usage: plot.py [DIR]  (default docs/accuracy; reads DIR/study.csv, writes the PNGs there)."""
import csv
import math
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

FLOOR = 1e-9  # errors below this are drawn at it (log axes)


def load(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fnum(s):
    try:
        return float(s)
    except ValueError:
        return math.nan


def category(r):
    """The sweep a run belongs to: its colour."""
    if r["skin"] != 0.1:
        return "skin %g d" % r["skin"]
    if r["rebuild"] != 0:
        return "rebuild every %d" % r["rebuild"]
    soft = "" if r["softening"] == 1 else ", E/%g" % r["softening"]
    return r["precision"] + soft


def combine(rows):
    """(family, executor) -> quantity -> setting -> combined point over the family's variants."""
    out = defaultdict(lambda: defaultdict(dict))
    for row in rows:
        family = row["problem"].split("/")[0]
        r = {
            "precision": row["precision"],
            "dt": fnum(row["dt_fraction"]),
            "softening": fnum(row["softening"]),
            "skin": fnum(row["skin_fraction"]),
            "rebuild": int(row["rebuild_interval"]),
        }
        key = (r["precision"], r["dt"], r["softening"], r["skin"], r["rebuild"])
        err, cost = fnum(row["error"]), fnum(row["wall_s_per_sim_s"])
        if err == 0:
            continue  # the reference setting of a problem without a closed form (error 0 by definition)
        cur = out[(family, row["executor"])][row["quantity"]].get(key)
        if cur is None:
            cur = dict(r, error=err, cost=cost, status=row["status"])
        else:
            cur["error"] = max(cur["error"], err) if not (math.isnan(err) or math.isnan(cur["error"])) else math.nan
            cur["cost"] = max(cur["cost"], cost)
            if row["status"] != "ok":
                cur["status"] = row["status"]
        out[(family, row["executor"])][row["quantity"]][key] = cur
    return out


def pareto(points):
    """Points (cost, error) not beaten on both by another: sorted by cost, errors strictly decreasing."""
    front, best = [], math.inf
    for c, e in sorted(points):
        if e < best:
            front.append((c, e))
            best = e
    return front


def colours(cats):
    cmap = plt.get_cmap("tab20")
    return {c: cmap(i % 20) for i, c in enumerate(sorted(cats))}


def noise_floor(outdir):
    """(family, executor, quantity) -> relative standard error of the packing mean at the reference setting."""
    path = os.path.join(outdir, "noise.csv")
    out = {}
    if not os.path.exists(path):
        return out
    vals = defaultdict(list)
    for row in load(path):
        v = fnum(row["value"])
        if not math.isnan(v):
            vals[(row["problem"].split("/")[0], row["executor"], row["quantity"])].append(v)
    for key, v in vals.items():
        if len(v) > 1:
            mean = sum(v) / len(v)
            sd = math.sqrt(sum((x - mean) ** 2 for x in v) / (len(v) - 1))
            out[key] = sd / math.sqrt(len(v)) / abs(mean)
    return out


def draw(family, executor, quantities, outdir, noise):
    names = sorted(quantities)
    n = len(names)
    cats = {category(p) for q in names for p in quantities[q].values()}
    col = colours(cats)
    # Error against cost.
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    for ax, q in zip(axes[0], names):
        pts = list(quantities[q].values())
        for cat in sorted(cats):
            ok = [p for p in pts if category(p) == cat and p["status"] == "ok" and not math.isnan(p["error"])]
            if ok:
                ax.scatter([p["cost"] for p in ok], [max(p["error"], FLOOR) for p in ok], s=18, color=col[cat], label=cat)
        bad = [p for p in pts if p["status"] != "ok" and not math.isnan(p["cost"]) and p["cost"] > 0]
        if bad:
            ax.scatter([p["cost"] for p in bad], [max(p["error"], FLOOR) if not math.isnan(p["error"]) else 1.0 for p in bad],
                       marker="x", s=22, color="0.6", label="failed (any mode)")
        front = pareto([(p["cost"], max(p["error"], FLOOR)) for p in pts
                        if p["status"] == "ok" and not math.isnan(p["error"]) and p["cost"] > 0])
        if front:
            xs, ys = zip(*front)
            ax.step(xs, ys, where="post", color="k", lw=1.2, label="Pareto front")
            ax.scatter(xs, ys, facecolors="none", edgecolors="k", s=50)
        if (family, executor, q) in noise:
            ax.axhline(noise[(family, executor, q)], ls="--", color="r", lw=1,
                       label="packing scatter (std. error of the mean)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall s per simulated s (%s)" % executor)
        ax.set_ylabel("relative error")
        ax.set_title("%s: %s" % (family, q))
        ax.grid(True, which="major", alpha=0.3)
    axes[0][-1].legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "%s_%s_cost.png" % (family, executor)), dpi=90)
    plt.close(fig)

    # Error against dt, one line per precision and softening (default skin, automatic rebuilds).
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    for ax, q in zip(axes[0], names):
        lines = defaultdict(list)
        for p in quantities[q].values():
            if p["skin"] == 0.1 and p["rebuild"] == 0:
                lines[category(p)].append(p)
        for cat, pts in sorted(lines.items()):
            pts.sort(key=lambda p: p["dt"])
            ok = [p for p in pts if p["status"] == "ok" and not math.isnan(p["error"])]
            if ok:
                ax.plot([p["dt"] for p in ok], [max(p["error"], FLOOR) for p in ok], "o-", ms=3, color=col[cat], label=cat)
            first_bad = next((p for p in pts if p["status"] != "ok"), None)
            if first_bad is not None:
                y = first_bad["error"] if not math.isnan(first_bad["error"]) else 1.0
                ax.scatter([first_bad["dt"]], [min(max(y, FLOOR), 10.0)], marker="X", s=70, color=col[cat], edgecolors="k")
                ax.annotate(first_bad["status"], (first_bad["dt"], min(max(y, FLOOR), 10.0)), fontsize=6,
                            xytext=(3, 3), textcoords="offset points")
        if (family, executor, q) in noise:
            ax.axhline(noise[(family, executor, q)], ls="--", color="r", lw=1,
                       label="packing scatter (std. error of the mean)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("dt / Rayleigh time")
        ax.set_ylabel("relative error")
        ax.set_title("%s: %s (X = first failure)" % (family, q))
        ax.grid(True, which="major", alpha=0.3)
    axes[0][-1].legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "%s_%s_dt.png" % (family, executor)), dpi=90)
    plt.close(fig)


def main():
    outdir = sys.argv[1] if len(sys.argv) > 1 else "docs/accuracy"
    rows = load(os.path.join(outdir, "study.csv"))
    groups = combine(rows)
    noise = noise_floor(outdir)
    for (family, executor), quantities in sorted(groups.items()):
        draw(family, executor, quantities, outdir, noise)
        print("wrote %s/%s_%s_{cost,dt}.png" % (outdir, family, executor))


if __name__ == "__main__":
    main()
