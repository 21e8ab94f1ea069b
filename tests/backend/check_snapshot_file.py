"""Checks the snapshot file layout from outside C++.

usage: check_snapshot_file.py SAMPLE_WRITER WORK_DIR

Runs the sample writer, then reads the .h5 with h5py and the .xmf with xml.etree: every HDF reference in the
sidecar must resolve, relative to the .xmf, to a dataset of the declared dimensions and number type.
"""
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np

XDMF_TYPES = {
    ("Float", "8"): np.dtype("f8"), ("Float", "4"): np.dtype("f4"),
    ("Int", "4"): np.dtype("i4"), ("UInt", "8"): np.dtype("u8"),
    ("UInt", "4"): np.dtype("u4"), ("Char", "1"): np.dtype("i1"),
}


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def check(cond, msg):
    if not cond:
        fail(msg)


def check_h5(path):
    with h5py.File(path, "r") as f:
        check(f.attrs["format"] == "pflow-snapshots", "root format attribute")
        check(int(f.attrs["format_version"]) == 1, "format_version")
        check(f.attrs["units"] == "SI", "units")
        steps = sorted(int(k) for k in f["snapshots"].keys())
        check(steps == [0, 100, 200], f"steps {steps}")
        g = f["snapshots/100"]
        check(g.attrs["time"] == 1e-3 and g.attrs["time"].dtype == np.float64, "time attribute")
        check(int(g.attrs["step"]) == 100 and g.attrs["step"].dtype == np.int64, "step attribute")
        check(int(g.attrs["n"]) == 25 and g.attrs["n"].dtype == np.uint64, "n attribute")
        expected = {
            "id": ("u8", (25,), ""), "position": ("f8", (25, 3), "m"), "velocity": ("f4", (25, 3), "m/s"),
            "angular_velocity": ("f8", (25, 3), "rad/s"), "radius": ("f8", (25,), "m"),
            "material": ("i4", (25,), ""), "contacts": ("u4", (25,), ""), "flags": ("i1", (25,), ""),
        }
        check(sorted(g.keys()) == sorted(expected), f"datasets {sorted(g.keys())}")
        for name, (dtype, shape, unit) in expected.items():
            d = g[name]
            check(d.dtype == np.dtype(dtype) and d.shape == shape, f"{name}: {d.dtype} {d.shape}")
            check(d.attrs["unit"] == unit, f"{name} unit {d.attrs['unit']!r}")
        check(g["id"][3] == 1003, "id values")
        check(np.allclose(g["position"][2], [0.12, 0.22, 0.32]), f"position values {g['position'][2]}")
        check(f["snapshots/200/position"].shape == (0, 3), "empty snapshot shape")
        geo = f["geometry"]
        check(geo["vertices"].shape == (5, 3) and geo["vertices"].attrs["unit"] == "m", "vertices")
        check(geo["triangles"].dtype == np.uint32 and geo["triangles"].shape == (3, 3), "triangles")
        for name in ("triangle_mesh", "triangle_surface", "triangle_material"):
            check(geo[name].dtype == np.int32 and geo[name].shape == (3,), name)
        check([s.decode() if isinstance(s, bytes) else s for s in geo["mesh_names"][()]] == ["floor", "wall"],
              "mesh_names")
        check(geo["plane_point"].shape == (1, 3) and geo["plane_normal"].shape == (1, 3), "planes")
        check(list(geo["plane_material"][()]) == [2], "plane_material")
        check(f["xdmf/polyvertex_index"].shape == (25,), "polyvertex index length")
        check(list(f["xdmf/polyvertex_index"][()]) == list(range(25)), "polyvertex index values")


def check_xmf(xmf, h5):
    root = ET.parse(xmf).getroot()  # raises on malformed XML
    check(root.tag == "Xdmf" and root.get("Version") == "3.0", "root element")
    temporal = root.find("Domain/Grid")
    check(temporal.get("CollectionType") == "Temporal", "temporal collection")
    steps = temporal.findall("Grid")
    check(len(steps) == 3, f"{len(steps)} time steps")
    check([s.find("Time").get("Value") for s in steps] == ["0", "0.001", "0.002"], "times")
    for s in steps:
        check(s.get("CollectionType") == "Spatial", "spatial collection per step")
        names = [g.get("Name") for g in s.findall("Grid")]
        check(names == ["particles", "geometry"], f"grids {names}")
    particles = steps[1].find("Grid[@Name='particles']")
    attrs = {a.get("Name"): a for a in particles.findall("Attribute")}
    check(sorted(attrs) == sorted(["id", "velocity", "angular_velocity", "radius", "material", "contacts", "flags"]),
          f"attributes {sorted(attrs)}")
    check(attrs["velocity"].get("AttributeType") == "Vector" and attrs["radius"].get("AttributeType") == "Scalar",
          "attribute types")
    topo = particles.find("Topology")
    check(topo.get("TopologyType") == "Polyvertex" and topo.get("NumberOfElements") == "25", "polyvertex topology")

    base = os.path.dirname(os.path.abspath(xmf))
    n_refs = 0
    with h5py.File(h5, "r") as f:
        for item in root.iter("DataItem"):
            if item.get("Format") != "HDF":
                continue
            file_part, _, dset = item.text.strip().partition(":")
            check(not os.path.isabs(file_part), f"absolute reference {file_part}")
            check(os.path.samefile(os.path.join(base, file_part), h5), f"reference to {file_part}")
            check(dset in f, f"missing dataset {dset}")
            d = f[dset]
            dims = tuple(int(x) for x in item.get("Dimensions").split())
            check(d.shape == dims, f"{dset}: shape {d.shape} vs Dimensions {dims}")
            want = XDMF_TYPES[(item.get("NumberType"), item.get("Precision"))]
            check(d.dtype == want, f"{dset}: dtype {d.dtype} vs {want}")
            n_refs += 1
    check(n_refs > 20, f"only {n_refs} HDF references")


def main():
    writer, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    h5 = os.path.join(work, "sample.h5")
    subprocess.run([writer, h5], check=True)
    xmf = os.path.join(work, "sample.xmf")
    check(os.path.exists(xmf), "sidecar missing")
    check_h5(h5)
    check_xmf(xmf, h5)
    # The pair still works after moving it elsewhere: references are relative.
    moved = os.path.join(work, "moved")
    os.makedirs(moved)
    shutil.move(h5, os.path.join(moved, "sample.h5"))
    shutil.move(xmf, os.path.join(moved, "sample.xmf"))
    check_xmf(os.path.join(moved, "sample.xmf"), os.path.join(moved, "sample.h5"))
    print("1 passed, 0 failed")


if __name__ == "__main__":
    main()
