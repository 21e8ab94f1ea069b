"""pflow.Client against the real local stack: submit, watch, fetch (compared with the HDF5 file that `pflow fetch`
writes, read by h5py directly), jobs, nodes, cancel, and the errors a user meets."""
import os
import time

import h5py
import numpy as np
import pytest

import pflow
from conftest import LONG, SCENE, wait_nodes


def test_submit_watch_fetch_equals_the_file(stack, tmp_path):
    c = stack.client()
    job = c.submit(SCENE)
    assert job.id.startswith("job-") and job.state in ("queued", "starting", "running", "succeeded"), job
    assert job.particles == 400
    events = list(c.watch(job.id))
    assert events[-1].job.state == "succeeded", events[-1]
    steps = [e.job.progress["step"] for e in events]
    assert steps == sorted(steps) and steps[-1] == events[-1].job.progress["total_steps"]
    snap = c.fetch(job.id)
    assert snap.n == 400 and snap["position"].shape == (400, 3)
    assert np.all(np.diff(snap["id"].astype(np.int64)) > 0)  # id order
    assert snap.units["position"] == "m"
    assert snap.grid is not None and "solid_fraction" in snap.grid
    assert snap.geometry.surface_names[0] == "bin/bottom", snap.geometry.surface_names
    assert "kinetic_energy" in snap.series and len(snap.series["time"]) >= 2
    out = tmp_path / "fetched.h5"
    stack.cli("fetch", job.id, "--last", "-o", str(out))
    with h5py.File(out) as f:
        g = f["snapshots"][str(snap.step)]
        order = np.argsort(g["id"][...])
        for name in ("id", "position", "velocity", "radius"):
            assert np.array_equal(snap[name], g[name][...][order]), name
        assert np.array_equal(snap.grid["solid_fraction"], g["grid/solid_fraction"][...])
        assert np.array_equal(snap.series["kinetic_energy"], f["probes/kinetic_energy"][...])
    with pflow.open(out) as r:  # the same through the results reader
        assert r.steps[-1] == snap.step
        assert np.array_equal(r.last["position"], snap["position"])
    earlier = c.fetch(job.id, step=c.steps(job.id)[0][0], fields=["position", "id"], grid=False, geometry=False, series=False)
    assert earlier.fields == ["id", "position"] and earlier.grid is None and earlier.step == 0


def test_jobs_nodes_cancel(stack):
    c = stack.client()
    nodes = wait_nodes(c)
    assert nodes[0].name == "node-a" and nodes[0].devices[0]["kind"] == "cpu"
    job = c.submit(LONG)
    end = time.time() + 60
    while c.job(job.id).state != "running" and time.time() < end:
        time.sleep(0.2)
    assert any(j.id == job.id for j in c.jobs())
    assert c.cancel(job.id).state in ("cancelling", "cancelled")
    final = c.wait(job.id)
    assert final.state == "cancelled", final
    assert job.id in [j.id for j in c.jobs(all=True)]
    assert job.id not in [j.id for j in c.jobs()]


def test_scene_dicts_and_their_errors(stack):
    c = stack.client()
    scene = pflow.Scene.load(SCENE).with_overrides({"simulation.duration": 0.005, "simulation.snapshot_interval": 0.005})
    job = c.submit(scene.data, name="from-a-dict")
    assert job.name == "from-a-dict"
    assert c.wait(job.id).state == "succeeded"
    bad = scene.with_overrides({"materials[0].density": -1})
    with pytest.raises(pflow.SceneError) as e:
        c.submit(bad)
    assert "materials[0].density" in [path for path, _ in e.value.errors], e.value.errors


def test_errors_are_clear_exceptions(stack, tmp_path, monkeypatch):
    monkeypatch.setenv("PFLOW_CONFIG", str(tmp_path / "none.yaml"))  # not the machine's own settings
    with pytest.raises(pflow.Unauthenticated) as e:
        stack.client(token="pflow_" + "0" * 43).jobs()
    assert "token is not valid" in str(e.value)
    c = stack.client()
    with pytest.raises(pflow.NotFound) as e:
        c.job("job-999999")
    assert "job-999999" in str(e.value)
    with pytest.raises(pflow.NotFound):
        c.fetch("job-999999")
    with pytest.raises(pflow.Unavailable) as e:
        stack.client(manager="127.0.0.1:1").jobs()
    assert "cannot reach 127.0.0.1:1" in str(e.value)
    with pytest.raises(pflow.InvalidArgument):
        pflow.Client(manager="10.1.2.3:50051", insecure=True)  # a token in the clear
    with pytest.raises(pflow.InvalidArgument) as e:
        pflow.Client(manager=stack.addr("manager"), ca="")
    assert "no pflow CA" in str(e.value)


def test_configuration_as_the_cli(stack, tmp_path, monkeypatch):
    cfg = tmp_path / "config.yaml"
    cfg.write_text("manager: %s\nbackend: %s\nca: %s\ntoken: %s\n" % (stack.addr("manager"), stack.addr("backend"), stack.ca,
                                                                      stack.token))
    monkeypatch.setenv("PFLOW_CONFIG", str(cfg))
    assert [n.name for n in pflow.Client().nodes()] == ["node-a"]
    monkeypatch.setenv("PFLOW_MANAGER", "127.0.0.1:1")  # the environment before the file
    with pytest.raises(pflow.Unavailable):
        pflow.Client().nodes()
