"""pflow's services from Python: the manager (submit, jobs, job, nodes, cancel, delete, watch) and the back-end
(fetch), over gRPC with the CLI's configuration and the same errors (errors.py), each call with a deadline."""
import os
import time

import numpy as np

from .config import Endpoints
from .errors import Error, Refused, SceneError, from_rpc
from .results import Geometry, Grid, Snapshot

CONTROL_DEADLINE = 10.0  # s, queries and control calls (as the CLI's)
BULK_DEADLINE = 600.0    # s, a snapshot's stream

_STATES = {0: "unknown", 1: "queued", 2: "starting", 3: "running", 4: "succeeded", 5: "failed", 6: "cancelling", 7: "cancelled",
           8: "requeued", 9: "building"}
FINAL = ("succeeded", "failed", "cancelled")


def _stubs():
    try:
        from pflow.backend.v1 import snapshot_service_pb2, snapshot_service_pb2_grpc
        from pflow.common.v1 import types_pb2
        from pflow.manager.v1 import manager_service_pb2, manager_service_pb2_grpc
    except ImportError as e:
        raise Error("pflow's gRPC stubs are missing (%s): install the package with pip, or put a build's python/ folder on "
                    "sys.path" % e) from None
    return manager_service_pb2, manager_service_pb2_grpc, snapshot_service_pb2, snapshot_service_pb2_grpc, types_pb2


class Job:
    """A job as the manager reports it: id, name, owner, state ("queued", "running", "succeeded", ...), reason,
    particles, devices [(node, "gpu"|"cpu", index)], progress {step, total_steps, time_s, duration_s,
    particle_steps_per_s, eta_s}, attempts, max_attempts, exit_code, model_uri, slurm_job_id and the times."""

    def __init__(self, pb):
        self.id = pb.id
        self.name = pb.name
        self.owner = pb.owner
        self.state = _STATES.get(pb.state, "unknown")
        self.reason = pb.reason
        self.particles = pb.particles
        self.devices = [(d.node, "gpu" if d.kind == 1 else "cpu", d.index) for d in pb.devices]
        p = pb.progress
        self.progress = {"step": p.step, "total_steps": p.total_steps, "time_s": p.time, "duration_s": p.duration,
                         "particle_steps_per_s": p.particle_steps_per_second, "eta_s": p.eta_seconds}
        self.attempts = pb.attempts
        self.max_attempts = pb.max_attempts
        self.exit_code = pb.exit_code
        self.model_uri = pb.model_uri
        self.model = pb.model
        self.slurm_job_id = pb.slurm_job_id
        self.submitted_at, self.started_at, self.finished_at = pb.submitted_at, pb.started_at, pb.finished_at

    @property
    def done(self):
        return self.state in FINAL

    @property
    def fraction(self):
        t = self.progress["total_steps"]
        return self.progress["step"] / t if t > 0 else 0.0

    def __repr__(self):
        return "Job(%s, %s, %s%s)" % (self.id, self.name, self.state, ": " + self.reason if self.reason else "")


class JobEvent:
    def __init__(self, pb):
        self.job = Job(pb.job)
        self.message = pb.message

    def __repr__(self):
        return "JobEvent(%r, %r)" % (self.job, self.message)


class Node:
    """A node and its devices: name, agent ("slurm" under placement through Slurm), lost, slurm_state, cpu_load,
    devices [{index, kind, name, state, job, memory_total_bytes, memory_used_bytes, utilization}]."""

    def __init__(self, pb):
        self.name = pb.name
        self.agent = pb.agent_address
        self.lost = pb.lost
        self.slurm_state = pb.slurm_state
        self.slurm_reason = pb.slurm_reason
        self.cpu_load = pb.cpu_load
        states = {1: "free", 2: "busy", 3: "lost"}
        self.devices = [{"index": d.ref.index, "kind": "gpu" if d.ref.kind == 1 else "cpu", "name": d.name,
                         "state": states.get(d.state, "?"), "job": d.job_id, "memory_total_bytes": d.memory_total_bytes,
                         "memory_used_bytes": d.memory_used_bytes, "utilization": d.utilization} for d in pb.devices]

    def __repr__(self):
        return "Node(%s, %d devices%s)" % (self.name, len(self.devices), ", lost" if self.lost else "")


class Client:
    """The services: Client(manager="host:port", backend="host:port", token=..., ca=FILE, insecure=False); every
    argument left out is looked up as the CLI does (PFLOW_MANAGER, PFLOW_BACKEND, PFLOW_TOKEN, PFLOW_CA,
    PFLOW_INSECURE, then ~/.config/pflow/config.yaml or PFLOW_CONFIG, then loopback)."""

    def __init__(self, manager=None, backend=None, token=None, ca=None, insecure=None):
        self._pb, self._grpc, self._spb, self._sgrpc, self._types = _stubs()
        self.endpoints = Endpoints(manager, backend, token, ca, insecure)
        self._mchan = self.endpoints.channel(self.endpoints.manager)
        self._bchan = self.endpoints.channel(self.endpoints.backend)
        self._manager = self._grpc.ManagerServiceStub(self._mchan)
        self._backend = self._sgrpc.SnapshotServiceStub(self._bchan)

    def close(self):
        self._mchan.close()
        self._bchan.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # --- calls ---------------------------------------------------------------------------------------------------

    def _call(self, method, request, what, address, timeout=CONTROL_DEADLINE, idempotent=True):
        import grpc

        wait = 0.25
        for attempt in range(4 if idempotent else 1):
            try:
                return method(request, timeout=timeout, metadata=self.endpoints.metadata())
            except grpc.RpcError as e:
                if e.code() != grpc.StatusCode.UNAVAILABLE or attempt == 3 or not idempotent:
                    raise from_rpc(e, what, address) from None
                time.sleep(wait)
                wait *= 2

    def _m(self, name, request, what, **kw):
        return self._call(getattr(self._manager, name), request, what, self.endpoints.manager, **kw)

    # --- the manager ---------------------------------------------------------------------------------------------

    def submit(self, scene, name=None, wait=True, max_devices=0, build_timeout=600):
        """Submits a scene (a path, a dict or a Scene) with the files it names (meshes, particle CSV) and waits while
        the manager builds it. Returns the Job (queued, or already starting); raises SceneError with the scene's
        findings, Refused when it may not wait for devices or can never fit."""
        from .scene import Scene

        if isinstance(scene, (str, os.PathLike)):
            path = os.fspath(scene)
            with open(path) as f:
                text = f.read()
            s = Scene.load(path)
            scene_name = os.path.basename(path)
            base = os.path.dirname(os.path.abspath(path))
        else:
            s = scene if isinstance(scene, Scene) else Scene(scene)
            text = s.to_yaml()
            scene_name = "scene.yaml"
            base = s.base_dir or os.getcwd()
        req = self._pb.SubmitJobRequest(name=name or os.path.splitext(scene_name)[0], scene_yaml=text, scene_name=scene_name,
                                        wait=wait, max_devices=max_devices)
        for f in s.files():
            full = f if os.path.isabs(f) else os.path.join(base, f)
            with open(full, "rb") as fh:
                req.files.add(path=f, content=fh.read())
        job = Job(self._m("SubmitJob", req, "submit " + scene_name, timeout=60, idempotent=False).job)
        end = time.time() + build_timeout
        while job.state == "building" and time.time() < end:
            time.sleep(0.2)
            job = self.job(job.id)
        if job.state == "failed" and job.attempts == 0:
            if job.reason.startswith("refused"):
                raise Refused("submit %s: %s" % (scene_name, job.reason))
            raise SceneError.from_text("submit %s: %s" % (scene_name, job.reason), job.reason)
        return job

    def job(self, job_id):
        return Job(self._m("GetJob", self._pb.GetJobRequest(id=job_id), "job " + job_id))

    def jobs(self, all=False):  # noqa: A002 (the CLI's --all)
        """The caller's jobs (an admin's: everyone's): the active ones, or all with all=True."""
        resp = self._m("ListJobs", self._pb.ListJobsRequest(active_only=not all), "jobs")
        return [Job(j) for j in resp.jobs]

    def nodes(self):
        return [Node(n) for n in self._m("ListNodes", self._pb.ListNodesRequest(), "nodes").nodes]

    def cancel(self, job_id):
        return Job(self._m("CancelJob", self._pb.CancelJobRequest(id=job_id), "cancel " + job_id))

    def delete(self, job_id):
        """Deletes a finished job and its data on the back-end (its owner or an admin)."""
        self._m("DeleteJob", self._pb.DeleteJobRequest(id=job_id), "delete " + job_id, timeout=60)

    def watch(self, job_id, progress=False, timeout=7 * 24 * 3600.0):
        """Yields a JobEvent for the job now and for every change (state, progress) until it ends. progress=True draws
        a tqdm bar over its steps (when tqdm is installed). The stream's deadline is `timeout` seconds."""
        import grpc

        bar = None
        if progress:
            try:
                from tqdm.auto import tqdm
                bar = tqdm(total=1, desc=job_id, unit="step")
            except ImportError:
                bar = None
        try:
            stream = self._manager.WatchJob(self._pb.WatchJobRequest(id=job_id), timeout=timeout, metadata=self.endpoints.metadata())
            for pb in stream:
                ev = JobEvent(pb)
                if bar is not None:
                    total = ev.job.progress["total_steps"]
                    if total and bar.total != total:
                        bar.total = total
                    bar.n = ev.job.progress["step"]
                    bar.set_postfix_str(ev.job.state, refresh=False)
                    bar.refresh()
                yield ev
        except grpc.RpcError as e:
            raise from_rpc(e, "watch " + job_id, self.endpoints.manager) from None
        finally:
            if bar is not None:
                bar.close()

    def wait(self, job_id, progress=False):
        """Watches the job to its end and returns it."""
        last = None
        for ev in self.watch(job_id, progress=progress):
            last = ev.job
        return last if last is not None else self.job(job_id)

    # --- the back-end ----------------------------------------------------------------------------------------------

    def steps(self, job_id):
        """The job's snapshots on the back-end: [(step, time_s, particles)]."""
        resp = self._call(self._backend.ListSnapshots, self._spb.ListSnapshotsRequest(job_id=job_id), "snapshots of " + job_id,
                          self.endpoints.backend)
        return [(s.step, s.time, s.particles) for s in resp.snapshots]

    def fetch(self, job_id, step=None, fields=None, grid=True, geometry=True, series=True):
        """A snapshot of the job from the back-end (default: the last), as a Snapshot whose fields are in id order,
        with `.grid` (the grid fields), `.geometry` (the walls) and `.series` (the job's time series: /probes)."""
        import grpc

        req = self._spb.ReadSnapshotRequest(job_id=job_id, include_grid=grid, include_geometry=geometry, include_probes=series)
        if step is None:
            req.last = True
        else:
            req.step = int(step)
        if fields:
            req.fields.extend(fields)
        arrays = {1: {}, 2: {}, 3: {}, 4: {}}
        units = {1: {}, 2: {}, 3: {}, 4: {}}
        head = None
        spec = None
        try:
            for chunk in self._backend.ReadSnapshot(req, timeout=BULK_DEADLINE, metadata=self.endpoints.metadata()):
                head = head or chunk
                if chunk.section == 3 and chunk.HasField("grid"):
                    spec = chunk.grid
                _assemble(arrays[chunk.section], units[chunk.section], chunk.array)
        except grpc.RpcError as e:
            raise from_rpc(e, "fetch " + job_id, self.endpoints.backend) from None
        if head is None:
            raise Error("fetch %s: the back-end sent nothing" % job_id)
        particles = arrays[1]
        if "id" in particles:
            order = np.argsort(particles["id"], kind="stable")
            particles = {k: (v[order] if len(v) == len(order) else v) for k, v in particles.items()}
        g = None
        if spec is not None:
            g = Grid((spec.origin.x, spec.origin.y, spec.origin.z), spec.cell_size, list(spec.cells), arrays[3], units[3])
        snap = Snapshot(head.step, head.time, head.particles, particles, units[1], g)
        snap.geometry = Geometry(arrays[2])
        snap.series = arrays[4]
        snap.job_id = job_id
        return snap


_DTYPES = {1: "<f8", 2: "<f4", 3: "<i4", 4: "<u4", 5: "<i8", 6: "<u8"}


def _assemble(into, units, a):
    """Puts one ArrayChunk's rows into its array (allocated at its first piece)."""
    shape = tuple(int(s) for s in a.shape)
    if a.dtype == 7:  # strings: u32 length + UTF-8 bytes each
        out, data, i = into.setdefault(a.name, []), a.data, 0
        while i + 4 <= len(data):
            n = int.from_bytes(data[i:i + 4], "little")
            out.append(data[i + 4:i + 4 + n].decode())
            i += 4 + n
        units[a.name] = a.unit
        return
    dtype = np.dtype(_DTYPES.get(a.dtype, "<f8"))
    if a.name not in into:
        into[a.name] = np.empty(shape, dtype=dtype)
        units[a.name] = a.unit
    arr = into[a.name]
    if a.rows:
        rows = np.frombuffer(a.data, dtype=dtype).reshape((int(a.rows),) + shape[1:])
        arr[int(a.first_row):int(a.first_row) + int(a.rows)] = rows
