"""pflow.open, pflow.run and the scene builder on local runs (the CLI binary, no services)."""
import numpy as np
import pytest

import pflow
from conftest import SCENE


@pytest.fixture(scope="module")
def results():
    r = pflow.run(SCENE, **{"simulation.duration": 0.02, "simulation.snapshot_interval": 0.005})
    yield r
    r.close()


def test_run_and_open(results):
    assert results.steps[0] == 0 and len(results) == 5, results
    assert np.allclose(results.times, [0, 0.005, 0.01, 0.015, 0.02], atol=1e-5)
    s = results.last
    assert s.n == 400 and s["position"].shape == (400, 3) and s.units["velocity"] == "m/s"
    assert np.array_equal(s["id"], np.sort(s["id"]))
    first = results.snapshot(0)
    assert np.all(s["position"][:, 2] < first["position"][:, 2] + 1e-9)  # falling, row for row the same particles
    assert results.geometry.surface_names == ["bin/bottom", "bin/top", "bin/left", "bin/right", "bin/front", "bin/back"]
    tri = results.geometry.triangles_of("bin/bottom")
    assert tri.shape[1:] == (3, 3) and len(tri) >= 2 and np.all(tri[:, :, 2] == 0)  # the box's floor at z = 0
    assert "kinetic_energy" in results.series and len(results.series["time"]) >= 5
    with pytest.raises(pflow.NotFound):
        results.snapshot(123456789)
    with pytest.raises(KeyError):
        s["no_such_field"]


def test_to_xarray(results):
    xr = pytest.importorskip("xarray")
    ds = results.to_xarray(["position", "velocity"])
    assert isinstance(ds, xr.Dataset)
    assert ds["position"].dims == ("time", "particle", "component") and ds.sizes["time"] == 5 and ds.sizes["particle"] == 400
    assert ds["position"].attrs["units"] == "m"
    assert np.array_equal(ds["position"].isel(time=-1).values, results.last["position"])


def test_scene_builder_and_validate(tmp_path):
    scene = pflow.Scene.load(SCENE)
    summary = scene.validate()
    assert summary["particles"] == 400
    bad = scene.with_overrides({"materials[0].poisson_ratio": 0.7, "simulation.duration": -1})
    with pytest.raises(pflow.SceneError) as e:
        bad.validate()
    paths = [p for p, _ in e.value.errors]
    assert "materials[0].poisson_ratio" in paths and "simulation.duration" in paths, e.value.errors
    with pytest.raises(pflow.InvalidArgument):
        scene.with_overrides({"materials[5].friction": 0.1})
    path = scene.write(tmp_path / "copy.yaml")
    assert pflow.Scene.load(path).data == scene.data
    with pytest.raises(pflow.SceneError):
        pflow.run(bad)


def test_open_refuses_other_files(tmp_path):
    other = tmp_path / "other.h5"
    import h5py
    with h5py.File(other, "w") as f:
        f["x"] = [1]
    with pytest.raises(pflow.Error):
        pflow.open(other)
    with pytest.raises(pflow.NotFound):
        pflow.open(tmp_path / "missing.h5")
