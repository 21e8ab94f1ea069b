#!/usr/bin/python3
"""`pflow render` end to end: real snapshot files (a DEM hopper run, an SPH dam break, 10^6 particles built), real
headless Chromium. Each check reads the PNG back (matplotlib) and looks at its pixels. Usage:
render_test.py BIN_DIR SRC_DIR [name...]

  views        iso, top, front, side: 1600 x 1000 PNGs that show particles (coloured pixels) and walls, each different
  options      colour by height vs speed, a colour range, a colour map, clip, --size: each changes the picture
  slice        a grid-field slice (grey) with streamlines (orange), computed from a file without a grid
  sph          an SPH dam break coloured by pressure, boundary particles grey
  errors       bad options all named at once (exit 1), a missing file (exit 2), a missing step (exit 2)
  million      10^6 particles in under 20 s on this machine
  plot         pflow plot: a DEM run's series (with the mass past a flow plane) and an SPH run's probes as charts
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402

BIN, SRC = sys.argv[1], sys.argv[2]
PFLOW = os.path.join(BIN, "pflow")
TMP = tempfile.mkdtemp(prefix="pflow-render-test-")
BACKGROUND = np.array([0xF3, 0xF4, 0xF6]) / 255.0
ENV = dict(os.environ, OMP_WAIT_POLICY="passive")


def pflow(*args, check=True):
    r = subprocess.run([PFLOW, *args], capture_output=True, text=True, env=ENV, timeout=300)
    if check and r.returncode != 0:
        raise AssertionError(f"pflow {' '.join(args)} exited {r.returncode}: {r.stderr}")
    return r


def render(src, out, *args):
    path = os.path.join(TMP, out)
    r = pflow("render", src, "-o", path, "--json", *args)
    info = json.loads(r.stdout)
    img = mpimg.imread(path)[:, :, :3]
    return img, info


def stats(img):
    off = np.abs(img - BACKGROUND).sum(axis=2) > 0.12
    rgb = img[off]
    saturation = (rgb.max(axis=1) - rgb.min(axis=1)) if len(rgb) else np.zeros(0)
    return {"drawn": off.mean(), "coloured": (saturation > 0.25).mean() * off.mean(), "mean": img.mean(axis=(0, 1))}


def differ(a, b, at_least=0.01):
    d = np.abs(a - b).sum(axis=2) > 0.1
    return d.mean() > at_least


_files = {}


def hopper():
    if "hopper" not in _files:
        path = os.path.join(TMP, "hopper.h5")
        pflow("run", os.path.join(SRC, "examples/hopper_discharge.yaml"), "-o", path, "--steps", "12000", "--progress", "0")
        _files["hopper"] = path
    return _files["hopper"]


def check_views():
    src = hopper()
    pictures = {}
    for view in ("iso", "top", "front", "side"):
        img, info = render(src, f"view-{view}.png", "--view", view)
        assert img.shape == (1000, 1600, 3), f"{view}: {img.shape}"
        s = stats(img)
        print(f"  {view}: {100 * s['drawn']:.1f} % drawn, {100 * s['coloured']:.2f} % coloured, {info['wall_s']:.1f} s")
        assert s["drawn"] > 0.03, f"{view}: almost blank ({s['drawn']:.4f})"
        assert s["coloured"] > 0.002, f"{view}: no coloured particles"
        pictures[view] = img
    names = list(pictures)
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            assert differ(pictures[names[i]], pictures[names[j]]), f"{names[i]} and {names[j]} look the same"
    # Walls without particles: the hopper's surfaces alone still draw.
    img, _ = render(src, "walls.png", "--no-particles")
    s = stats(img)
    assert s["drawn"] > 0.03 and s["coloured"] < 0.001, f"walls only: drawn {s['drawn']:.3f}, coloured {s['coloured']:.4f}"


def check_options():
    src = hopper()
    speed, _ = render(src, "speed.png", "--color-by", "speed")
    height, _ = render(src, "height.png", "--color-by", "height")
    assert differ(speed, height, 0.002), "colour by height looks like colour by speed"
    ranged, _ = render(src, "range.png", "--color-by", "speed", "--range", "0", "0.01")
    assert differ(speed, ranged, 0.002), "--range changed nothing"
    grey, _ = render(src, "grey.png", "--color-by", "speed", "--colormap", "grey")
    assert stats(grey)["coloured"] < stats(speed)["coloured"] / 3, "--colormap grey still coloured"
    clipped, _ = render(src, "clip.png", "--clip", "y=0")
    assert differ(speed, clipped, 0.005), "--clip changed nothing"
    small, _ = render(src, "small.png", "--size", "800x600")
    assert small.shape == (600, 800, 3), small.shape
    bad = pflow("render", src, "-o", os.path.join(TMP, "x.png"), "--color-by", "nonesuch", check=False)
    assert bad.returncode != 0 and "nonesuch" in bad.stderr, bad.stderr


def check_slice():
    src = hopper()
    img, _ = render(src, "slice.png", "--slice", "y=0", "--field", "solid_fraction", "--streamlines")
    grey = (np.abs(img - img.mean(axis=2, keepdims=True)).sum(axis=2) < 0.02) & (np.abs(img - BACKGROUND).sum(axis=2) > 0.12)
    orange = (img[:, :, 0] > 0.8) & (img[:, :, 1] > 0.2) & (img[:, :, 1] < 0.55) & (img[:, :, 2] < 0.3)
    print(f"  slice: {100 * grey.mean():.1f} % grey, {100 * orange.mean():.2f} % streamline pixels")
    assert grey.mean() > 0.01, "no grey slice"
    assert orange.mean() > 0.0005, "no streamlines"
    img2, _ = render(src, "slice-t.png", "--slice", "y=0", "--field", "granular_temperature", "--colormap", "inferno")
    assert differ(img, img2), "another field looks the same"


def check_sph():
    path = os.path.join(TMP, "dam.h5")
    pflow("run", os.path.join(SRC, "examples/dam_break_2d.yaml"), "-o", path, "--steps", "1500", "--progress", "0")
    img, info = render(path, "dam.png", "--color-by", "pressure")
    s = stats(img)
    print(f"  dam break: {100 * s['drawn']:.1f} % drawn, {100 * s['coloured']:.2f} % coloured")
    assert s["coloured"] > 0.005, "fluid not coloured"
    neutral = (np.abs(img - img.mean(axis=2, keepdims=True)).sum(axis=2) < 0.03) & (np.abs(img - BACKGROUND).sum(axis=2) > 0.12)
    assert neutral.mean() > 0.002, "boundary particles not drawn grey"
    img2, _ = render(path, "dam-slice.png", "--slice", "y=0", "--field", "mean_velocity", "--streamlines")
    assert stats(img2)["drawn"] > 0.05, "the fluid's slice is empty"


def check_errors():
    src = hopper()
    r = pflow("render", src, "-o", "/nonexistent/dir/x.png", "--view", "diagonal", "--clip", "w=1", "--streamlines",
              "--size", "100x100", check=False)
    assert r.returncode == 1, r
    for what in ("--view 'diagonal'", "--clip 'w=1'", "--streamlines: needs --slice", "/nonexistent/dir", "width 100"):
        assert what in r.stderr, f"'{what}' not in: {r.stderr}"
    r = pflow("render", os.path.join(TMP, "missing.h5"), "-o", os.path.join(TMP, "m.png"), check=False)
    assert r.returncode == 2 and "no such file" in r.stderr, (r.returncode, r.stderr)
    r = pflow("render", src, "--step", "7", "-o", os.path.join(TMP, "s.png"), check=False)
    assert r.returncode != 0 and "no snapshot at step 7" in r.stderr, (r.returncode, r.stderr)
    assert not os.path.exists(os.path.join(TMP, "s.png")), "a failed render left a file"


def check_million():
    path = os.path.join(TMP, "million.h5")
    pflow("build", os.path.join(SRC, "tests/data/render_million.yaml"), "-o", path)
    t0 = time.monotonic()
    img, info = render(path, "million.png")
    wall = time.monotonic() - t0
    print(f"  10^6 particles: {wall:.1f} s ({info['page']})")
    assert info["particles"] == 1000000, info
    assert stats(img)["drawn"] > 0.1, "almost blank"
    assert wall < 20, f"{wall:.1f} s for 10^6 particles (limit 20 s)"


def check_plot():
    # Past the gate's opening at 0.15 s, so that the mass past the orifice grows (the example names that plane).
    src = os.path.join(TMP, "hopper-discharged.h5")
    pflow("run", os.path.join(SRC, "examples/hopper_discharge.yaml"), "-o", src, "--steps", "45000", "--progress", "0")
    path = os.path.join(TMP, "series.png")
    r = pflow("plot", src, "-o", path, "--json")
    img = mpimg.imread(path)[:, :, :3]
    assert img.shape == (1000, 1600, 3), img.shape
    lines = np.zeros(img.shape[:2], bool)
    for hexc in ("#1f77b4",):  # the first line colour of every panel
        c = np.array([int(hexc[i:i + 2], 16) for i in (1, 3, 5)]) / 255.0
        lines |= np.abs(img - c).sum(axis=2) < 0.15
    print(f"  DEM series: {100 * lines.mean():.2f} % line pixels ({json.loads(r.stdout)['wall_s']:.1f} s)")
    assert lines.mean() > 0.002, "no curves drawn"
    import h5py
    with h5py.File(src, "r") as f:
        names = sorted(k for k in f["probes"].keys())
        mass = f["probes/mass_past:orifice"][:]
        ke = f["probes/kinetic_energy"][:]
    for want in ("contacts", "coordination", "kinetic_energy", "mass_past:orifice", "time", "wall_contacts"):
        assert want in names, f"{want} not in {names}"
    assert (ke >= 0).all() and ke.max() > 0, "kinetic energy"
    # A bead may bounce back across the plane: the mass past it may dip by a bead's mass (4e-6 kg), no more.
    assert (np.diff(mass) >= -2e-5).all(), "the mass past the orifice went down"
    assert mass[-1] > 1e-3, f"{mass[-1]} kg past the orifice by t = 0.31 s: the hopper did not discharge"
    r = pflow("plot", src, "-o", os.path.join(TMP, "one.png"), "--series", "kinetic_energy")
    bad = pflow("plot", src, "-o", os.path.join(TMP, "none.png"), "--series", "nonesuch", check=False)
    assert bad.returncode != 0 and "nonesuch" in bad.stderr, bad.stderr
    dam = os.path.join(TMP, "dam-probes.h5")
    pflow("run", os.path.join(SRC, "examples/dam_break_3d.yaml"), "-o", dam, "--steps", "30", "--progress", "0")
    pflow("plot", dam, "-o", os.path.join(TMP, "dam-series.png"))


CHECKS = {"views": check_views, "options": check_options, "slice": check_slice, "sph": check_sph, "errors": check_errors,
          "million": check_million, "plot": check_plot}

if __name__ == "__main__":
    names = sys.argv[3:] or list(CHECKS)
    failed = []
    for name in names:
        t0 = time.monotonic()
        try:
            CHECKS[name]()
            print(f"{name}: passed ({time.monotonic() - t0:.1f} s)")
        except Exception:  # noqa: BLE001 - report every check
            traceback.print_exc()
            print(f"{name}: FAILED")
            failed.append(name)
    shutil.rmtree(TMP, ignore_errors=True)
    sys.exit(1 if failed else 0)
