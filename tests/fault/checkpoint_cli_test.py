#!/usr/bin/env python3
"""pflow run --checkpoint-every / --resume on the hopper example and the 2D dam break (issue 18, label fault).

The run resumed from a checkpoint writes the snapshots of the uninterrupted run: the same steps, and every
particle's position, velocity and angular velocity bit for bit. A checkpoint cut off half-written is passed over
for the one before it (still bit for bit); with neither readable the run stops with a clear error, no crash.
Usage: checkpoint_cli_test.py PFLOW_BINARY REPO_ROOT WORK_DIR
"""
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np

pflow, root, work = sys.argv[1], sys.argv[2], sys.argv[3]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
scene = os.path.join(root, "examples", "hopper_discharge.yaml")
TOTAL, FIRST, EVERY = 6000, 3500, 1000


def run(*args, expect=0):
    p = subprocess.run([pflow, "--log-level", "info", "run", *args, "--threads", "2", "--progress", "0"],
                       capture_output=True, text=True, cwd=work)
    if p.returncode != expect:
        sys.exit(f"pflow run {' '.join(args)}: exit {p.returncode}, expected {expect}\n{p.stdout}\n{p.stderr}")
    return p.stdout + p.stderr


def snapshots(path):
    out = {}
    with h5py.File(path, "r") as f:
        for name, g in f["snapshots"].items():
            order = np.argsort(g["id"][()])
            out[int(name)] = {k: g[k][()][order] for k in ("position", "velocity", "angular_velocity", "density") if k in g}
    return out


def expect_same_tail(resumed_path, straight, after):
    resumed = snapshots(resumed_path)
    later = sorted(s for s in straight if s > after)
    if sorted(resumed) != later:
        sys.exit(f"{resumed_path}: snapshot steps {sorted(resumed)}, the uninterrupted run's after step {after}: {later}")
    for step, arrays in resumed.items():
        for field, values in arrays.items():
            if not np.array_equal(values, straight[step][field]):
                worst = np.abs(values - straight[step][field]).max()
                sys.exit(f"{resumed_path}: step {step} {field} differs from the uninterrupted run (largest {worst:g})")
    return len(resumed)


def checkpoint_step(path):
    with h5py.File(path, "r") as f:
        return int(f.attrs["step"])


run(scene, "-o", "straight.h5", "--steps", str(TOTAL))
straight = snapshots(os.path.join(work, "straight.h5"))
log = run(scene, "-o", "first.h5", "--steps", str(FIRST), "--checkpoint-every", str(EVERY))
ckpt = os.path.join(work, "first.ckpt.h5")
assert os.path.exists(ckpt) and os.path.exists(ckpt + ".1"), f"the last two checkpoints are kept\n{log}"
assert not os.path.exists(ckpt + ".tmp"), "no temporary file is left behind"
last, before = checkpoint_step(ckpt), checkpoint_step(ckpt + ".1")
assert EVERY * 2 < before < last <= FIRST, (before, last)
with h5py.File(ckpt, "r") as f:
    assert f.attrs["format"] == "pflow-checkpoint" and f.attrs["solver"] == "dem", dict(f.attrs)
    assert "history_disp" in f["particles"] and "force" in f["particles"], list(f["particles"])
    assert f["particles/position"].attrs["unit"] == "m"

# Resumed from the last checkpoint: the uninterrupted run's snapshots after it, bit for bit.
log = run("--resume", ckpt, "-o", "resumed.h5", "--steps", str(TOTAL))
assert f"resumed from {ckpt} at step {last}" in log, log
n = expect_same_tail(os.path.join(work, "resumed.h5"), straight, last)
print(f"resumed at step {last}: {n} snapshots identical to the uninterrupted run's")

# The last checkpoint cut off mid-file (a crash while it was renamed in, a bad disk): the one before is used, and
# a left-over temporary file is ignored.
shutil.copy(ckpt + ".1", os.path.join(work, "cut.ckpt.h5.1"))
with open(ckpt, "rb") as src, open(os.path.join(work, "cut.ckpt.h5"), "wb") as dst:
    data = src.read()
    dst.write(data[: len(data) // 2])
with open(os.path.join(work, "cut.ckpt.h5.tmp"), "wb") as dst:
    dst.write(b"half a checkpoint")
log = run("--resume", "cut.ckpt.h5", "-o", "from_before.h5", "--steps", str(TOTAL))
assert "resuming from the checkpoint before it" in log, log
n = expect_same_tail(os.path.join(work, "from_before.h5"), straight, before)
print(f"cut-off checkpoint passed over; resumed at step {before}: {n} snapshots identical")

# Neither readable: a clear error (exit 2, I/O), nothing written over.
os.remove(os.path.join(work, "cut.ckpt.h5.1"))
log = run("--resume", "cut.ckpt.h5", "-o", "nothing.h5", "--steps", str(TOTAL), expect=2)
assert "cannot open the checkpoint" in log, log
assert not os.path.exists(os.path.join(work, "nothing.h5"))
log = run("--resume", "cut.ckpt.h5", "--steps", str(TOTAL), expect=1)
assert "name the output file" in log, log

# The wall-clock interval (default 600 s): at 1 ms a checkpoint follows the first rebuild.
run(scene, "-o", "wall.h5", "--steps", "1500", "--checkpoint-wall", "0.001")
assert os.path.exists(os.path.join(work, "wall.ckpt.h5")), "a checkpoint by wall-clock time"
# An SPH scene (the 2D dam break at the seed's resolution): the same, by simulated time.
dam = os.path.join(root, "examples", "dam_break_2d.yaml")
run(dam, "-o", "dam.h5", "--steps", "1500")
dam_straight = snapshots(os.path.join(work, "dam.h5"))
run(dam, "-o", "dam_first.h5", "--steps", "1000", "--checkpoint-every", "300")
dam_ckpt = os.path.join(work, "dam_first.ckpt.h5")
with h5py.File(dam_ckpt, "r") as f:
    assert f.attrs["solver"] == "sph", dict(f.attrs)
    dam_last = int(f.attrs["step"])
run("--resume", dam_ckpt, "-o", "dam_resumed.h5", "--steps", "1500")
n = expect_same_tail(os.path.join(work, "dam_resumed.h5"), dam_straight, dam_last)
print(f"SPH resumed at step {dam_last}: {n} snapshots identical to the uninterrupted run's")
# output.checkpoint_interval in the scene: a checkpoint after each multiple of it (simulated seconds).
with open(dam) as src:
    text = src.read().replace("output:\n", "output:\n  checkpoint_interval: 0.05\n", 1)
timed = os.path.join(work, "dam_timed.yaml")
with open(timed, "w") as dst:
    dst.write(text)
log = run(timed, "-o", "dam_timed.h5", "--steps", "1600", "--checkpoint-wall", "0")
with h5py.File(os.path.join(work, "dam_timed.ckpt.h5"), "r") as f, h5py.File(os.path.join(work, "dam_timed.ckpt.h5.1"), "r") as g:
    assert 0.05 <= g.attrs["time"] < 0.1 <= f.attrs["time"], (g.attrs["time"], f.attrs["time"])
print("checkpoint CLI: OK")
