"""pflow from Python: submit and follow jobs through pflow's services, and read results as numpy arrays.

    import pflow
    client = pflow.Client()                      # the CLI's configuration: PFLOW_*, ~/.config/pflow/config.yaml
    job = client.submit("examples/hopper.yaml")
    for event in client.watch(job.id, progress=True):
        pass
    snap = client.fetch(job.id)                  # the last snapshot: particle fields by id order
    results = pflow.open("run.h5")               # a snapshot file of `pflow run` or `pflow fetch`
    results = pflow.run("scene.yaml", **{"simulation.duration": 0.1})   # a local run through the CLI

docs/python.md has the whole API.
"""
import pkgutil

# The gRPC stubs (pflow.manager.v1, ...) are generated at build time: inside this package once installed, or in a
# build tree's python/ folder on sys.path (the tests).
__path__ = pkgutil.extend_path(__path__, __name__)  # noqa: F821

from .errors import (Error, InvalidArgument, NotFound, PermissionDenied, Refused, SceneError, Unauthenticated,  # noqa: E402
                     Unavailable)
from .results import Geometry, Grid, Results, Snapshot, open  # noqa: E402,A004
from .scene import Scene  # noqa: E402
from .local import run, validate  # noqa: E402
from .client import Client, Job, JobEvent, Node  # noqa: E402

__all__ = ["Client", "Job", "JobEvent", "Node", "Results", "Snapshot", "Grid", "Geometry", "Scene", "open", "run", "validate",
           "Error", "InvalidArgument", "NotFound", "PermissionDenied", "Refused", "SceneError", "Unauthenticated", "Unavailable"]
__version__ = "0.1.0"
