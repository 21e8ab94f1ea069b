#!/usr/bin/python3
"""Draws one snapshot of a pflow result file (HDF5) to a PNG: particles as spheres coloured by
speed, walls as translucent triangles, in a 3D view and a side view (x-z)."""
import argparse
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("h5")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--step", type=int, help="snapshot step (default: the last)")
    a = ap.parse_args()
    with h5py.File(a.h5, "r") as f:
        steps = sorted(int(s) for s in f["snapshots"].keys())
        if not steps:
            sys.exit("no snapshots in " + a.h5)
        step = a.step if a.step is not None else steps[-1]
        g = f["snapshots"][str(step)]
        x = g["position"][...]
        r = g["radius"][...]
        v = np.linalg.norm(g["velocity"][...], axis=1)
        t = float(g.attrs["time"])
        tris = None
        if "geometry" in f and "vertices" in f["geometry"]:
            verts = f["geometry"]["vertices"][...]
            tris = verts[f["geometry"]["triangles"][...]]

    fig = plt.figure(figsize=(12, 5.5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    if tris is not None:
        ax.add_collection3d(Poly3DCollection(tris, alpha=0.08, facecolor="grey", edgecolor="k", linewidths=0.3))
    lo, hi = x.min(axis=0) - r.max(), x.max(axis=0) + r.max()
    if tris is not None:
        lo = np.minimum(lo, tris.reshape(-1, 3).min(axis=0))
        hi = np.maximum(hi, tris.reshape(-1, 3).max(axis=0))
    span = (hi - lo).max()
    # marker area in points^2 roughly matching the sphere size in the view
    size = (r / span * 300) ** 2 * 3
    sc = ax.scatter(x[:, 0], x[:, 1], x[:, 2], c=v, s=size, cmap="viridis", depthshade=True)
    ax.set_xlim(lo[0], lo[0] + span)
    ax.set_ylim(lo[1], lo[1] + span)
    ax.set_zlim(lo[2], lo[2] + span)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"{len(x)} particles, step {step}, t = {t:.4g} s")
    fig.colorbar(sc, ax=ax, shrink=0.6, label="speed [m/s]")

    ax2 = fig.add_subplot(1, 2, 2)
    order = np.argsort(x[:, 1])[::-1]
    # Far particles first, so the near ones are drawn over them; shaded by speed like the 3D view.
    ax2.scatter(x[order, 0], x[order, 2], c=v[order], s=size[order] * 2, cmap="viridis", edgecolors="none",
                vmin=sc.get_clim()[0], vmax=sc.get_clim()[1])
    if tris is not None:
        for tri in tris:
            ax2.plot(np.append(tri[:, 0], tri[0, 0]), np.append(tri[:, 2], tri[0, 2]), color="k", lw=0.3, alpha=0.3)
    ax2.set_aspect("equal")
    ax2.set_xlabel("x [m]")
    ax2.set_ylabel("z [m]")
    ax2.set_title("side view from -y (colour: speed; walls at t = 0)")
    fig.tight_layout()
    fig.savefig(a.output, dpi=110)
    print(f"wrote {a.output} (step {step}, t = {t:.4g} s)")


if __name__ == "__main__":
    main()
