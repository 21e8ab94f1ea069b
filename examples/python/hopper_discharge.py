#!/usr/bin/env python3
"""A notebook's cells as a script: submit the hopper (examples/hopper_discharge.yaml) to pflow's services, follow it,
and plot the mass discharged through the orifice over time, with the steady flow rate.

    python3 examples/python/hopper_discharge.py [-o hopper_discharge.png]

The services are found as the CLI finds them (PFLOW_MANAGER, PFLOW_BACKEND, PFLOW_TOKEN, PFLOW_CA or
~/.config/pflow/config.yaml; deploy/local/start.sh writes one). docs/python.md shows the picture.
"""
import argparse
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pflow  # noqa: E402

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("-o", "--output", default="hopper_discharge.png")
args = parser.parse_args()

# 1. Submit: the scene file and the meshes it names go to the manager, which builds it and queues the job.
client = pflow.Client()
scene = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "hopper_discharge.yaml")
job = client.submit(scene)
print("submitted", job)

# 2. Follow it to the end (a progress bar when tqdm is installed).
final = client.wait(job.id, progress=True)
print("finished", final)
if final.state != "succeeded":
    raise SystemExit("the job %s: %s" % (final.state, final.reason))

# 3. The last snapshot from the back-end, with the job's time series (the mass past the orifice's plane).
snap = client.fetch(job.id, fields=["id", "velocity"], grid=False, geometry=False)
t = snap.series["time"]
mass = snap.series["mass_past:orifice"]  # kg: the particles whose centre is below the orifice
total = mass[-1]

# 4. The steady flow rate: the slope of the discharged mass between 20 % and 80 % of what left (Beverloo's regime).
steady = (mass > 0.2 * total) & (mass < 0.8 * total)
rate, offset = np.polyfit(t[steady], mass[steady], 1)
print("discharged %.4f kg; steady flow rate %.4f kg/s (%d samples from t = %.3f to %.3f s)" % (
    total, rate, steady.sum(), t[steady][0], t[steady][-1]))

fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=120)
ax.plot(t, 1e3 * mass, lw=2, label="mass past the orifice (pflow series)")
ax.plot(t[steady], 1e3 * (rate * t[steady] + offset), "k--", lw=1, label="steady rate %.1f g/s" % (1e3 * rate))
ax.axvline(0.15, color="grey", lw=0.8, ls=":")
ax.text(0.152, 0.05 * 1e3 * total, "gate opens", color="grey", fontsize=8)
ax.set_xlabel("time [s]")
ax.set_ylabel("discharged mass [g]")
ax.set_title("%s: %d beads, %s" % (job.id, snap.n, final.devices[0][0] if final.devices else ""))
ax.legend(loc="upper left")
ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(args.output)
print("wrote", args.output)
