#!/usr/bin/python3
"""End to end over real sockets on loopback: frontend, back-end, manager and node agents as separate processes,
driven by the `pflow` CLI. Each scenario is one function; run all (default) or some: e2e_test.py BIN_DIR SRC_DIR [name...]

  equivalence  submit -> running -> succeeded -> fetch equals `pflow run` of the same scene (ids, positions)
  cancel       cancel mid-run ends the workers within seconds and frees the device
  queue        a second job waits while the device is busy and starts when it frees
  restart      killing the manager mid-job and restarting it keeps the job and its state; the job finishes
  killworker   killing a worker requeues its job, which goes on from its last checkpoint on the back-end; killing it
               on its last attempt fails it with the reason and frees the device
  resume       a job killed after a checkpoint goes on from it and ends bit for bit as an uninterrupted `pflow run`
  agentrestart an agent killed while its worker runs: started again, it stops the worker and the job goes on from its
               checkpoint, ending bit for bit as an uninterrupted run
  multinode    two agents (node-a on 127.0.0.1, node-b on 127.0.0.2) and one job across both through mpirun + hostfile
  errors       unknown ids, double cancel, missing steps, a back-end that is down: clear errors, exit codes
  users        users see only their own jobs, an admin all; tokens; `pflow delete` removes a job and its files
  web          pflow-web: a user's jobs as JSON, the last snapshot's positions as float32 frames, 401 and 403;
               pflow render and pflow plot of the job through the back-end (another user's: refused); its series
  sph          an SPH dam break (solver: sph) submitted, followed and fetched: the same particles, probe series and
               CSV as `pflow run`, and the fluid's grid fields
"""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import traceback

import h5py
import numpy as np

from ports import free_port  # tests/services/ports.py, beside this file

BIN, SRC = sys.argv[1], sys.argv[2]
PFLOW = os.path.join(BIN, "pflow")
SCENE = os.path.join(SRC, "tests/data/service_scene.yaml")
LONG = os.path.join(SRC, "tests/data/service_long_scene.yaml")
SPH_SCENE = os.path.join(SRC, "tests/data/service_sph_scene.yaml")
# Passive OpenMP waits: the workers' threads sleep instead of spinning when the machine is shared (a parallel ctest),
# where spinning threads slow every process down many times over.
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_WAIT_POLICY="passive")
for _k in ("PFLOW_TOKEN", "PFLOW_CA", "PFLOW_INSECURE", "PFLOW_CONFIG", "PFLOW_MANAGER", "PFLOW_BACKEND"):
    ENV.pop(_k, None)  # the stack's own settings only
CERTS = os.path.join(SRC, "deploy/local/certs.sh")


def can_bind(host):
    try:
        with socket.socket() as s:
            s.bind((host, 0))
        return True
    except OSError:
        return False


class Stack:
    """The four services as child processes in a temporary folder, over mutual TLS as deploy/local/start.sh runs them;
    the CLI calls as the first admin (config.yaml: the CA and the admin's token)."""

    def __init__(self, agents=(("node-a", "127.0.0.1"),), manager_args=(), cpu_slots=1, start_agents=True):
        self.dir = tempfile.mkdtemp(prefix="pflow-e2e-")
        self.ports = {k: free_port() for k in ("manager", "frontend", "backend")}
        self.procs = {}
        self.agents = agents
        self.manager_args = list(manager_args)
        self.cpu_slots = cpu_slots
        os.makedirs(os.path.join(self.dir, "logs"))
        self.tls = os.path.join(self.dir, "tls")
        subprocess.run([CERTS, self.tls, "manager", "frontend", "backend", "web"] + ["node:" + n for n, _ in agents], check=True,
                       capture_output=True)
        self.config = os.path.join(self.dir, "config.yaml")
        self.start("frontend", [os.path.join(BIN, "pflow-frontend"), "--listen", self.addr("frontend"), "--models", os.path.join(self.dir, "models"),
                                "--tls-dir", self.tls])
        self.start_backend()
        self.start_manager()
        self.write_config()
        if start_agents:  # else `agents` only names the nodes that get certificates (Slurm's, tests/services/slurm_test.py)
            for node, host in agents:
                self.start_agent(node, host)
            self.wait_nodes(len(agents))

    def addr(self, name):
        return "127.0.0.1:%d" % self.ports[name]

    def start(self, name, cmd):
        log = open(os.path.join(self.dir, "logs", name + ".log"), "ab")
        self.procs[name] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=ENV, start_new_session=True)

    def start_backend(self):
        self.start("backend", [os.path.join(BIN, "pflow-backend"), "--listen", self.addr("backend"), "--data", os.path.join(self.dir, "snapshots"),
                               "--manager", self.addr("manager"), "--tls-dir", self.tls])

    def start_manager(self):
        # No scenario here waits for a node to be declared lost (the chaos suite does): a timeout of 30 s, not 6, so
        # that a heartbeat held up by a loaded machine (15 s seen once on two cores) does not requeue a job twice.
        self.start("manager", [os.path.join(BIN, "pflow-manager"), "--listen", self.addr("manager"), "--db", os.path.join(self.dir, "manager.db"),
                               "--frontend", self.addr("frontend"), "--backend", self.addr("backend"), "--heartbeat-timeout", "30",
                               "--heartbeat-interval", "1", "--tick", "0.5", "--tls-dir", self.tls,
                               "--admin-token-file", os.path.join(self.dir, "admin.token")] + self.manager_args)

    def write_config(self):
        """The CLI's settings: the CA and the first admin's token (written by the manager on its first start)."""
        path = os.path.join(self.dir, "admin.token")
        end = time.time() + 30
        while not (os.path.exists(path) and os.path.getsize(path) > 0):
            if time.time() > end:
                raise AssertionError("the manager wrote no admin token; logs in %s" % self.dir)
            time.sleep(0.05)
        self.admin_token = open(path).read().strip()
        with open(self.config, "w") as f:
            f.write("ca: %s\ntoken: %s\n" % (os.path.join(self.tls, "ca.crt"), self.admin_token))

    def start_agent(self, node, host):
        port = free_port() if host == "127.0.0.1" else 0
        listen = "%s:%d" % (host, port)
        cmd = [os.path.join(BIN, "pflow-agent"), "--node", node, "--listen", listen, "--manager", self.addr("manager"),
               "--workdir", os.path.join(self.dir, "agent-" + node), "--worker", os.path.join(BIN, "pflow-worker"),
               "--cpu-slots", str(self.cpu_slots), "--force-cpu", "--heartbeat-interval", "1", "--grace", "3",
               "--rsh-agent", os.path.join(SRC, "deploy/local/pflow-rsh"), "--tls-dir", self.tls]
        self.start("agent-" + node, cmd)

    def cli(self, *args, check=True, timeout=300, token=None):
        cmd = [PFLOW, "--manager", self.addr("manager"), "--backend", self.addr("backend")] + list(args)
        env = dict(ENV, PFLOW_CONFIG=self.config)
        if token is not None:
            env["PFLOW_TOKEN"] = token
        r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
        if check and r.returncode != 0:
            raise AssertionError("%s -> %d\n%s%s" % (" ".join(args), r.returncode, r.stdout, r.stderr))
        return r

    def json(self, *args):
        return json.loads(self.cli(*args, "--json").stdout)

    def wait_nodes(self, n, timeout=30):
        end = time.time() + timeout
        while time.time() < end:
            r = self.cli("nodes", "--json", check=False)
            if r.returncode == 0:
                nodes = json.loads(r.stdout)
                if len([x for x in nodes if x["devices"] and not x["lost"]]) >= n:
                    return nodes
            time.sleep(0.3)
        raise AssertionError("agents did not register in %d s; logs in %s" % (timeout, self.dir))

    def wait_state(self, job, states, timeout=120):
        end = time.time() + timeout
        last = None
        while time.time() < end:
            # A manager just started again (tests/chaos) may not answer yet: a failed call is retried, not fatal.
            r = self.cli("job", job, "--json", check=False)
            if r.returncode != 0:
                last = "the CLI exited %d: %s" % (r.returncode, (r.stderr or r.stdout).strip()[-300:])
                time.sleep(0.5)
                continue
            last = json.loads(r.stdout)
            if last["state"] in states:
                return last
            time.sleep(0.3)
        raise AssertionError("job %s did not reach %s in %d s (last: %s)" % (job, states, timeout, last))

    def submit(self, scene, *extra):
        return self.json("submit", scene, *extra)["id"]

    def device_states(self):
        return [d["state"] for n in self.json("nodes") for d in n["devices"]]

    def kill(self, name, sig=signal.SIGKILL):
        p = self.procs.pop(name)
        os.killpg(p.pid, sig)
        p.wait(timeout=30)

    def close(self):
        for name in sorted(self.procs, key=lambda n: 0 if n.startswith("agent") else 1):
            p = self.procs[name]
            try:
                os.killpg(p.pid, signal.SIGTERM)
                p.wait(timeout=15)
            except Exception:
                try:
                    os.killpg(p.pid, signal.SIGKILL)
                except Exception:
                    pass
        if os.environ.get("PFLOW_E2E_KEEP"):
            print("kept", self.dir)
        else:
            shutil.rmtree(self.dir, ignore_errors=True)


def equivalence():
    s = Stack()
    try:
        job = s.submit(SCENE)
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"})
        assert final["state"] == "succeeded", final
        assert final["particles"] == 400
        out = os.path.join(s.dir, "fetched.h5")
        s.cli("fetch", job, "--last", "-o", out)
        ref = os.path.join(s.dir, "ref.h5")
        subprocess.run([PFLOW, "run", SCENE, "-o", ref, "--progress", "0"], check=True, capture_output=True, env=ENV)
        with h5py.File(out) as a, h5py.File(ref) as b:
            sa = max(a["snapshots"], key=int)
            sb = max(b["snapshots"], key=int)
            assert sa == sb, (sa, sb)
            ga, gb = a["snapshots"][sa], b["snapshots"][sb]
            ia, ib = ga["id"][...], gb["id"][...]
            oa, ob = np.argsort(ia), np.argsort(ib)
            assert np.array_equal(ia[oa], ib[ob])
            assert np.array_equal(ga["position"][...][oa], gb["position"][...][ob]), "positions differ"
            assert "grid" in ga and "solid_fraction" in ga["grid"], "no grid fields"
            assert "geometry" in a
        listing = s.cli("jobs", "--all").stdout
        assert job in listing and "succeeded" in listing, listing
    finally:
        s.close()


def cancel():
    s = Stack()
    try:
        job = s.submit(LONG)
        s.wait_state(job, {"running"})
        t0 = time.time()
        s.cli("cancel", job)
        final = s.wait_state(job, {"cancelled", "failed", "succeeded"}, timeout=30)
        assert final["state"] == "cancelled", final
        took = time.time() - t0
        assert took < 15, "cancel took %.1f s" % took
        assert s.device_states() == ["free"], s.device_states()
        r = s.cli("watch", job, check=False)
        assert r.returncode == 6, (r.returncode, r.stdout, r.stderr)  # a cancelled job's exit code
    finally:
        s.close()


def queue():
    s = Stack()
    try:
        a = s.submit(LONG)
        s.wait_state(a, {"running"})
        b = s.submit(SCENE, "--wait")
        assert s.json("job", b)["state"] == "queued"
        refused = s.cli("submit", SCENE, "--no-wait", check=False)
        assert refused.returncode == 5, (refused.returncode, refused.stderr)
        s.cli("cancel", a)
        final = s.wait_state(b, {"succeeded", "failed"}, timeout=180)
        assert final["state"] == "succeeded", final
    finally:
        s.close()


def restart():
    s = Stack()
    try:
        a = s.submit(LONG)
        s.wait_state(a, {"running"})
        q = s.submit(SCENE, "--wait")
        s.kill("manager")
        s.start_manager()
        s.wait_nodes(1)
        ja, jq = s.json("job", a), s.json("job", q)
        assert ja["state"] == "running", ja
        assert jq["state"] == "queued", jq
        time.sleep(3)  # progress reports resume against the new manager
        assert s.json("job", a)["progress"]["step"] > 0
        s.cli("cancel", a)
        assert s.wait_state(q, {"succeeded", "failed"}, timeout=180)["state"] == "succeeded"
    finally:
        s.close()


def kill_workers(job):
    """SIGKILL every pflow-worker process of `job`; returns their pids."""
    out = subprocess.run(["pgrep", "-f", "pflow-worker --job-id %s" % job], capture_output=True, text=True).stdout.split()
    assert out, "no worker process found"
    for pid in out:
        os.kill(int(pid), signal.SIGKILL)
    return set(out)


def killworker():
    # --max-attempts 2: the first kill puts the job back in the queue (attempt 1 of 2) and it starts again on the
    # device it freed; the second kill fails it, with the reason, and frees the device.
    s = Stack(manager_args=["--max-attempts", "2"])
    try:
        job = s.submit(LONG)
        s.wait_state(job, {"running"})
        log = os.path.join(s.dir, "agent-node-a", job + ".log")
        wait_for_log(log, "on the back-end")  # the first checkpoint (the scene takes one every 0.05 s simulated)
        first = kill_workers(job)
        end, last = time.time() + 60, None
        while time.time() < end:
            last = s.json("job", job)
            if last["attempts"] == 2 and last["state"] == "running":
                break
            time.sleep(0.3)
        assert last["attempts"] == 2 and last["state"] == "running", last
        assert last["max_attempts"] == 2, last
        assert "requeued" in last["reason"] and "attempt 1 of 2" in last["reason"], last
        # The second attempt went on from the job's last checkpoint on the back-end (the scene checkpoints every
        # 0.05 s of simulated time), not from the start.
        # 90 s: one run of the whole suite saw the second attempt's worker not log within 30 s (reruns take 2 s).
        end = time.time() + 90
        while time.time() < end and "resumed from its checkpoint" not in open(log).read():
            time.sleep(0.3)
        text = open(log).read()
        assert "resumed from its checkpoint at step" in text, text[-3000:]
        jobs = s.cli("jobs").stdout
        assert "2/2" in jobs, jobs
        second = kill_workers(job)
        assert not (first & second), (first, second)
        final = s.wait_state(job, {"failed", "succeeded", "cancelled"}, timeout=60)
        assert final["state"] == "failed", final
        assert "attempt 2 of 2" in final["reason"] and "signal 9" in final["reason"], final
        assert s.device_states() == ["free"], s.device_states()
    finally:
        s.close()


def write_resume_scene(s):
    """The service scene run for 0.4 s with a checkpoint every 0.05 s (simulated): long enough to interrupt."""
    scene = os.path.join(s.dir, "resume_scene.yaml")
    text = open(SCENE).read().replace("duration: 0.03", "duration: 0.4").replace("snapshot_interval: 0.01", "snapshot_interval: 0.1")
    with open(scene, "w") as f:
        f.write(text + "output:\n  checkpoint_interval: 0.05\n")
    return scene


def wait_for_log(log, text, timeout=180):
    end = time.time() + timeout
    while time.time() < end and (not os.path.exists(log) or text not in open(log).read()):
        time.sleep(0.1)
    assert text in open(log).read(), open(log).read()[-3000:]


def assert_same_as_run(s, job, scene):
    """The job's last snapshot equals an uninterrupted `pflow run` of the scene's, bit for bit."""
    out = os.path.join(s.dir, "fetched.h5")
    s.cli("fetch", job, "--last", "-o", out)
    ref = os.path.join(s.dir, "ref.h5")
    subprocess.run([PFLOW, "run", scene, "-o", ref, "--progress", "0"], check=True, capture_output=True, env=ENV)
    with h5py.File(out) as a, h5py.File(ref) as b:
        sa, sb = max(a["snapshots"], key=int), max(b["snapshots"], key=int)
        assert sa == sb, (sa, sb)
        ga, gb = a["snapshots"][sa], b["snapshots"][sb]
        oa, ob = np.argsort(ga["id"][...]), np.argsort(gb["id"][...])
        assert np.array_equal(ga["position"][...][oa], gb["position"][...][ob]), "positions differ after the resume"
        assert np.array_equal(ga["velocity"][...][oa], gb["velocity"][...][ob]), "velocities differ after the resume"


def run_interrupted(s, interrupt):
    """Submits the resume scene and calls interrupt(job) after the job's first checkpoint: the job must go on from it
    on its second attempt and end with the same particles, bit for bit, as an uninterrupted `pflow run`."""
    scene = write_resume_scene(s)
    job = s.submit(scene)
    s.wait_state(job, {"running"})
    log = os.path.join(s.dir, "agent-node-a", job + ".log")
    wait_for_log(log, "on the back-end")
    interrupt(job)
    final = s.wait_state(job, {"succeeded", "failed", "cancelled"}, timeout=120)
    assert final["state"] == "succeeded", final
    assert final["attempts"] == 2, final
    assert "resumed from its checkpoint at step" in open(log).read()
    assert_same_as_run(s, job, scene)


def resume():
    # A job killed after its first checkpoint goes on from it on the next attempt.
    s = Stack()
    try:
        run_interrupted(s, kill_workers)
    finally:
        s.close()


def agentrestart():
    # The agent dies (SIGKILL) while its worker runs on; started again, it stops the worker it finds, reports it, and
    # the manager requeues the job, which goes on from its checkpoint.
    s = Stack()
    orphans = []

    def restart_agent(job):
        s.kill("agent-node-a")
        orphans.extend(subprocess.run(["pgrep", "-f", "pflow-worker --job-id %s" % job], capture_output=True, text=True).stdout.split())
        assert orphans, "the worker should outlive its agent"
        s.start_agent("node-a", "127.0.0.1")

    try:
        run_interrupted(s, restart_agent)
        assert "restarted" in open(os.path.join(s.dir, "logs", "agent-node-a.log")).read()
        for pid in orphans:  # the first attempt's worker is gone
            assert not os.path.exists("/proc/%s" % pid) or "Z" in open("/proc/%s/stat" % pid).read().split(")")[-1][:3], pid
    finally:
        s.close()


def multinode():
    host_b = "127.0.0.2" if can_bind("127.0.0.2") else "127.0.0.1"
    s = Stack(agents=(("node-a", "127.0.0.1"), ("node-b", host_b)), manager_args=["--particles-per-cpu-slot", "100"])
    try:
        job = s.submit(SCENE)
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"}, timeout=240)
        assert final["state"] == "succeeded", final
        nodes = sorted({d["node"] for d in final["devices"]})
        assert nodes == ["node-a", "node-b"], final["devices"]
    finally:
        s.close()


def errors():
    s = Stack()
    try:
        r = s.cli("job", "no-such-job", check=False)
        assert r.returncode == 1 and "no-such-job" in r.stderr, (r.returncode, r.stderr)
        job = s.submit(SCENE)
        s.wait_state(job, {"succeeded"})
        r = s.cli("cancel", job, check=False)
        assert r.returncode == 1, (r.returncode, r.stderr)  # finished: FAILED_PRECONDITION
        r = s.cli("fetch", job, "--step", "999999", "-o", os.path.join(s.dir, "x.h5"), check=False)
        assert r.returncode == 1 and "999999" in r.stderr, (r.returncode, r.stderr)
        s.kill("backend")
        r = s.cli("fetch", job, "--last", "-o", os.path.join(s.dir, "y.h5"), check=False)
        assert r.returncode == 4 and "back-end" in r.stderr, (r.returncode, r.stderr)
    finally:
        s.close()


def users():
    """Users see and touch only their own jobs; an admin sees all; `pflow delete` removes a finished job and its files;
    the CLI refuses a negative step."""
    s = Stack()
    try:
        alice = s.json("admin", "user", "add", "alice")["token"]
        bob = s.json("admin", "user", "add", "bob")["token"]
        r = s.cli("admin", "user", "add", "mallory", "--admin", check=False, token=bob)
        assert r.returncode == 7 and "PERMISSION_DENIED" not in r.stderr and "admin" in r.stderr, (r.returncode, r.stderr)
        job = json.loads(s.cli("submit", SCENE, "--json", token=alice).stdout)["id"]
        assert json.loads(s.cli("job", job, "--json", token=alice).stdout)["owner"] == "alice"
        s.wait_state(job, {"succeeded"})
        r = s.cli("job", job, check=False, token=bob)
        assert r.returncode == 7 and "not yours" in r.stderr, (r.returncode, r.stderr)
        r = s.cli("fetch", job, "--last", "-o", os.path.join(s.dir, "b.h5"), check=False, token=bob)
        assert r.returncode == 7, (r.returncode, r.stderr)
        assert json.loads(s.cli("jobs", "--all", "--json", token=bob).stdout) == []
        assert [j["id"] for j in s.json("jobs", "--all")] == [job]  # the admin sees it
        r = s.cli("jobs", check=False, token="pflow_" + "0" * 64)
        assert r.returncode == 7 and "not valid" in r.stderr, (r.returncode, r.stderr)
        r = s.cli("fetch", job, "--step", "-1", "-o", os.path.join(s.dir, "n.h5"), check=False, token=alice)
        assert r.returncode == 1 and "--step -1" in r.stderr, (r.returncode, r.stderr)
        r = s.cli("delete", job, check=False, token=bob)
        assert r.returncode == 7, (r.returncode, r.stderr)
        data = os.path.join(s.dir, "snapshots", job + ".h5")
        assert os.path.exists(data)
        s.cli("delete", job, token=alice)
        assert not os.path.exists(data), "the job's snapshots are still there"
        r = s.cli("job", job, check=False, token=alice)
        assert r.returncode == 1, (r.returncode, r.stderr)
        nxt = json.loads(s.cli("submit", SCENE, "--json", token=alice).stdout)["id"]
        assert nxt != job, "an id was given twice"
    finally:
        s.close()


def web():
    """pflow-web over the real stack: a user's jobs as JSON, the last snapshot's positions as float32 frames equal to
    the fetched file's, no token -> 401, another user's job -> 403."""
    import struct
    import urllib.error
    import urllib.request
    s = Stack()
    try:
        port = free_port()
        s.start("web", [os.path.join(BIN, "pflow-web"), "--listen", "127.0.0.1:%d" % port, "--manager", s.addr("manager"),
                        "--backend", s.addr("backend"), "--tls-dir", s.tls])
        job = s.submit(SCENE)
        s.wait_state(job, {"succeeded"})
        bob = s.json("admin", "user", "add", "bob")["token"]

        def get(path, token):
            req = urllib.request.Request("http://127.0.0.1:%d%s" % (port, path))
            if token:
                req.add_header("Authorization", "Bearer " + token)
            try:
                with urllib.request.urlopen(req, timeout=30) as r:
                    return r.status, r.read()
            except urllib.error.HTTPError as e:
                return e.code, e.read()
        for _ in range(100):  # the viewer is up
            try:
                if get("/api/nodes", s.admin_token)[0] == 200:
                    break
            except OSError:
                pass
            time.sleep(0.1)
        assert get("/api/jobs?all=1", "")[0] == 401
        code, body = get("/api/jobs?all=1", s.admin_token)
        assert code == 200 and [j["id"] for j in json.loads(body)] == [job], (code, body[:300])
        assert get("/api/jobs/" + job, bob)[0] == 403
        code, body = get("/api/jobs/%s/snapshots/last?fields=position,id" % job, s.admin_token)
        assert code == 200, (code, body[:300])
        at, arrays = 0, {}
        while at < len(body):
            (n,) = struct.unpack_from("<I", body, at)
            h = json.loads(body[at + 4:at + 4 + n])
            at += 4 + n
            if "rows" in h:
                count = h["rows"] * h["components"]
                arrays.setdefault(h["name"], []).append(np.frombuffer(body, "<f4", count, at).reshape(h["rows"], h["components"]))
                at += 4 * count
        pos, ids = np.concatenate(arrays["position"]), np.concatenate(arrays["id"]).ravel()
        out = os.path.join(s.dir, "fetched.h5")
        s.cli("fetch", job, "--last", "-o", out)
        with h5py.File(out) as f:
            g = f["snapshots"][max(f["snapshots"], key=int)]
            order = np.argsort(g["id"][...])
            ref = g["position"][...][order].astype(np.float32)
        assert np.array_equal(pos[np.argsort(ids)], ref), "positions differ"
        # pflow render and pflow plot of the job, through the back-end over TLS; another user may not.
        png = os.path.join(s.dir, "job.png")
        info = json.loads(s.cli("render", job, "-o", png, "--json").stdout)
        assert info["particles"] == len(ids) and os.path.getsize(png) > 10000, info
        info = json.loads(s.cli("plot", job, "-o", os.path.join(s.dir, "plot.png"), "--json").stdout)
        r = s.cli("render", job, "-o", os.path.join(s.dir, "bob.png"), check=False, token=bob)
        assert r.returncode == 7 and not os.path.exists(os.path.join(s.dir, "bob.png")), (r.returncode, r.stderr)
        with h5py.File(out) as f:  # the job's series came with the fetch: energy, contacts, wall loads
            names = set(f["probes"].keys())
            assert {"time", "kinetic_energy", "contacts", "wall_contacts"} <= names, names
            assert any(n.startswith("force_z:") for n in names), names
    finally:
        s.close()


def sph():
    s = Stack()
    try:
        job = s.submit(SPH_SCENE)
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"})
        assert final["state"] == "succeeded", final
        assert final["particles"] == 1838, final["particles"]
        out = os.path.join(s.dir, "fetched.h5")
        r = s.cli("fetch", job, "--last", "-o", out)
        csv = os.path.join(s.dir, "fetched.probes.csv")
        assert csv in r.stdout, r.stdout
        ref = os.path.join(s.dir, "ref.h5")
        subprocess.run([PFLOW, "run", SPH_SCENE, "-o", ref, "--progress", "0"], check=True, capture_output=True, env=ENV)
        with h5py.File(out) as a, h5py.File(ref) as b:
            sa = max(a["snapshots"], key=int)
            sb = max(b["snapshots"], key=int)
            assert sa == sb, (sa, sb)
            ga, gb = a["snapshots"][sa], b["snapshots"][sb]
            assert abs(ga.attrs["time"] - 0.1) < 1e-12, ga.attrs["time"]
            ia, ib = ga["id"][...], gb["id"][...]
            oa, ob = np.argsort(ia), np.argsort(ib)
            assert np.array_equal(ia[oa], ib[ob])
            for name in ("position", "velocity", "pressure", "density"):
                assert np.array_equal(ga[name][...][oa], gb[name][...][ob]), name + " differs"
            grid = ga["grid"]
            assert "fluid_fraction" in grid and "mean_pressure" in grid and "granular_temperature" not in grid, list(grid)
            assert grid["mean_pressure"].attrs["unit"] in (b"Pa", "Pa")
            assert 0.5 < np.max(grid["fluid_fraction"][...]) < 1.5
            assert np.max(grid["mean_pressure"][...]) > 1000  # about rho g H = 3.9 kPa at the base
            pa, pb = a["probes"], b["probes"]
            assert list(pa) == list(pb) == ["time", "base", "front"], (list(pa), list(pb))
            for name in pa:
                assert np.array_equal(pa[name][...], pb[name][...]), "probe " + name + " differs"
            assert len(pa["time"]) == 21, len(pa["time"])  # t = 0 and every 5 ms to 0.1 s
        with open(csv) as f:
            lines = f.read().splitlines()
        assert lines[0] == "time [s],base [Pa],front [m]", lines[0]
        assert len(lines) == 22, len(lines)
    finally:
        s.close()


SCENARIOS = [equivalence, cancel, queue, restart, killworker, resume, agentrestart, multinode, errors, users, web, sph]

if __name__ == "__main__":
    wanted = sys.argv[3:] or [f.__name__ for f in SCENARIOS]
    failed = []
    for f in SCENARIOS:
        if f.__name__ not in wanted:
            continue
        t0 = time.time()
        try:
            f()
            print("PASS %-12s %.1f s" % (f.__name__, time.time() - t0), flush=True)
        except Exception as e:  # report and go on with the next scenario
            failed.append(f.__name__)
            print("FAIL %-12s %.1f s: %r" % (f.__name__, time.time() - t0, e), flush=True)
            traceback.print_exc()
    sys.exit(1 if failed else 0)
