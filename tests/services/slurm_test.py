#!/usr/bin/python3
"""pflow on a real Slurm (issue 23): a one-node cluster of Debian's slurm-wlm on loopback (deploy/slurm/start.sh,
two CPU slots), the frontend, the back-end and a manager with --placement slurm as processes over mutual TLS, driven
by the `pflow` CLI. Each scenario is one function; run all (default) or some: slurm_test.py BIN_DIR SRC_DIR [name...]

  equivalence  submit -> Slurm runs it -> succeeded; the job names its Slurm job; `pflow nodes` shows Slurm's node;
               the fetched last snapshot equals `pflow run` of the same scene
  pending      a job that needs the slots another holds waits with Slurm's reason (Resources); cancelled while
               pending it leaves Slurm; the running one cancelled ends within seconds
  killstep     the worker's step killed: the Slurm job FAILED, the pflow job requeued with the reason, a second Slurm
               job goes on from the last checkpoint and the job ends bit for bit as an uninterrupted `pflow run`
  nodefail     the node set DOWN while the job runs (scontrol update): Slurm ends it NODE_FAIL, the job is requeued
               with that reason and, the node back, finishes from its checkpoint bit for bit
  gres         a second cluster whose node declares two GPUs as GRES (on stand-in device files): `pflow nodes` shows
               them, a job asks --gpus-per-task=1 for each of its two ranks, Slurm gives each task its own GPU, and
               the job's devices are those GPUs; on a machine without a GPU the workers' CUDA executor fails and the
               job is FAILED with the worker's own message
  restart      the manager killed while a Slurm job runs and started again: it finds the job in Slurm and follows it
               to the end
Exit code 77 (skipped) where slurm-wlm is not installed.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import e2e_test as e2e  # noqa: E402  (the stack, the CLI and the comparisons of the agents' end-to-end test)

BIN, SRC = e2e.BIN, e2e.SRC
NODE = "pflow-node1"


class Cluster:
    """deploy/slurm/start.sh in a temporary folder; SLURM_CONF for everything started after it."""

    def __init__(self, cpus=2, gpus=0):
        # Started twice at most, each time in a new folder on new ports: a start that failed (its daemons' last log
        # lines are in start.sh's message) is printed and stopped before the second; two failures fail the scenario.
        for attempt in (1, 2):
            self.dir = tempfile.mkdtemp(prefix="pflow-slurm-")
            r = subprocess.run([os.path.join(SRC, "deploy/slurm/start.sh"), self.dir, "--cpus", str(cpus),
                                "--gpus", str(gpus)], capture_output=True, text=True)
            if r.returncode == 0:
                break
            subprocess.run([os.path.join(SRC, "deploy/slurm/stop.sh"), self.dir], capture_output=True)
            if attempt == 2:
                raise AssertionError("the Slurm cluster did not start, twice: %s%s" % (r.stdout, r.stderr))
            print("the Slurm cluster did not start (trying once more): %s%s" % (r.stdout, r.stderr), flush=True)
        self.conf = os.path.join(self.dir, "slurm.conf")
        e2e.ENV["SLURM_CONF"] = self.conf
        os.environ["SLURM_CONF"] = self.conf

    def scontrol_job(self, slurm_id):
        out = subprocess.run(["scontrol", "-o", "show", "job", slurm_id], capture_output=True, text=True, env=e2e.ENV).stdout
        return dict(w.split("=", 1) for w in out.split() if "=" in w)

    def close(self):
        subprocess.run([os.path.join(SRC, "deploy/slurm/stop.sh"), self.dir], capture_output=True)
        if not os.environ.get("PFLOW_E2E_KEEP"):
            shutil.rmtree(self.dir, ignore_errors=True)


class SlurmStack(e2e.Stack):
    def __init__(self, extra=()):
        self.extra = list(extra)
        super().__init__(agents=((NODE, "127.0.0.1"),), start_agents=False)

    def start_manager(self):
        self.manager_args = ["--placement", "slurm", "--slurm-workdir", os.path.join(self.dir, "slurm"),
                             "--slurm-worker", os.path.join(BIN, "pflow-worker"), "--slurm-poll", "0.5",
                             "--particles-per-cpu-slot", "200"] + self.extra
        super().start_manager()

    def worker_log(self, job, attempt=1):
        return os.path.join(self.dir, "slurm", "%s-%d.log" % (job, attempt))


def wait_slurm_nodes(s, timeout=30):
    end = time.time() + timeout
    while time.time() < end:
        r = s.cli("nodes", "--json", check=False)  # the manager may be starting
        nodes = json.loads(r.stdout) if r.returncode == 0 else []
        if nodes and len(nodes[0]["devices"]) == 2:
            return nodes
        time.sleep(0.3)
    raise AssertionError("the manager shows no Slurm node; logs in %s" % s.dir)


def equivalence(c):
    s = SlurmStack()
    try:
        nodes = wait_slurm_nodes(s)
        assert nodes[0]["node"] == NODE and nodes[0]["agent"] == "slurm", nodes
        assert nodes[0]["slurm_state"].startswith("IDLE"), nodes
        assert [d["kind"] for d in nodes[0]["devices"]] == ["cpu", "cpu"], nodes
        text = s.cli("nodes").stdout
        assert "Slurm state IDLE" in text, text
        scene = os.path.join(s.dir, "scene.yaml")  # the service scene with what it asks of Slurm
        with open(scene, "w") as f:
            f.write(open(e2e.SCENE).read() + "slurm: {partition: pflow, time_limit: \"10:00\"}\n")
        job = s.submit(scene)  # 400 particles at 200 a slot: two ranks, started by srun
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"}, timeout=180)
        assert final["state"] == "succeeded", final
        sid = final["slurm_job_id"]
        assert sid, final
        assert len(final["devices"]) == 2 and {d["node"] for d in final["devices"]} == {NODE}, final
        info = c.scontrol_job(sid)
        assert info["JobState"] == "COMPLETED" and info["NumTasks"] == "2", info
        assert info["TimeLimit"] == "00:10:00" and info["Partition"] == "pflow", info
        assert info["JobName"] == "pflow-" + job, info
        log = open(s.worker_log(job)).read()
        assert "2 rank(s)" in log, log[-2000:]
        out = os.path.join(s.dir, "fetched.h5")
        s.cli("fetch", job, "--last", "-o", out)
        ref = os.path.join(s.dir, "ref.h5")
        subprocess.run([e2e.PFLOW, "run", scene, "-o", ref, "--progress", "0"], check=True, capture_output=True, env=e2e.ENV)
        import h5py
        import numpy as np
        with h5py.File(out) as a, h5py.File(ref) as b:
            sa, sb = max(a["snapshots"], key=int), max(b["snapshots"], key=int)
            assert sa == sb, (sa, sb)
            ga, gb = a["snapshots"][sa], b["snapshots"][sb]
            oa, ob = np.argsort(ga["id"][...]), np.argsort(gb["id"][...])
            assert np.array_equal(ga["id"][...][oa], gb["id"][...][ob])
            # Two ranks against one process: forces are summed in global-id order, so bit for bit.
            assert np.array_equal(ga["position"][...][oa], gb["position"][...][ob]), "positions differ"
            assert np.array_equal(ga["velocity"][...][oa], gb["velocity"][...][ob]), "velocities differ"
    finally:
        s.close()


def pending(c):
    s = SlurmStack()
    try:
        wait_slurm_nodes(s)
        a = s.submit(e2e.LONG)  # both slots
        s.wait_state(a, {"running"}, timeout=60)
        b = s.submit(e2e.SCENE)  # both slots too: Slurm holds it
        end, jb = time.time() + 30, None
        while time.time() < end:
            jb = s.json("job", b)
            if "Resources" in jb["reason"] or "Priority" in jb["reason"]:
                break
            time.sleep(0.3)
        assert jb["state"] == "queued" and "waiting in Slurm as job " + jb["slurm_job_id"] in jb["reason"], jb
        assert "Resources" in jb["reason"] or "Priority" in jb["reason"], jb
        busy = [d for n in s.json("nodes") for d in n["devices"] if d["state"] == "busy"]
        assert len(busy) == 2 and {d["job"] for d in busy} == {a}, busy
        s.cli("cancel", b)
        assert s.json("job", b)["state"] == "cancelled"
        end = time.time() + 20
        while time.time() < end and c.scontrol_job(jb["slurm_job_id"]).get("JobState") != "CANCELLED":
            time.sleep(0.3)
        assert c.scontrol_job(jb["slurm_job_id"])["JobState"] == "CANCELLED"
        t0 = time.time()
        s.cli("cancel", a)
        final = s.wait_state(a, {"cancelled", "failed", "succeeded"}, timeout=60)
        assert final["state"] == "cancelled", final
        assert time.time() - t0 < 20, "cancel took %.1f s" % (time.time() - t0)
        assert c.scontrol_job(final["slurm_job_id"])["JobState"] in ("CANCELLED", "COMPLETED")
    finally:
        s.close()


def killstep(c):
    s = SlurmStack(["--max-attempts", "2"])
    try:
        wait_slurm_nodes(s)
        scene = e2e.write_resume_scene(s)
        job = s.submit(scene, "--max-devices", "1")  # one rank: bit for bit against one process
        s.wait_state(job, {"running"}, timeout=60)
        first = s.json("job", job)["slurm_job_id"]
        e2e.wait_for_log(s.worker_log(job, 1), "on the back-end")  # its first checkpoint
        e2e.kill_workers(job)
        end, last = time.time() + 90, None
        while time.time() < end:
            last = s.json("job", job)
            if last["attempts"] == 2 and last["state"] in ("running", "succeeded"):
                break
            time.sleep(0.3)
        assert last["attempts"] == 2, last
        assert last["slurm_job_id"] != first, last
        assert "requeued" in last["reason"] and "[Slurm job %s]" % first in last["reason"], last
        info = c.scontrol_job(first)
        assert info["JobState"] == "FAILED", info
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"}, timeout=180)
        assert final["state"] == "succeeded", final
        assert "resumed from its checkpoint at step" in open(s.worker_log(job, 2)).read()
        e2e.assert_same_as_run(s, job, scene)
    finally:
        s.close()


def nodefail(c):
    s = SlurmStack()
    try:
        wait_slurm_nodes(s)
        scene = e2e.write_resume_scene(s)
        job = s.submit(scene, "--max-devices", "1")
        s.wait_state(job, {"running"}, timeout=60)
        first = s.json("job", job)["slurm_job_id"]
        e2e.wait_for_log(s.worker_log(job, 1), "on the back-end")  # its first checkpoint
        subprocess.run(["scontrol", "update", "NodeName=" + NODE, "State=DOWN", "Reason=pflow test: node lost"], check=True,
                       env=e2e.ENV)
        try:
            end, last = time.time() + 60, None
            while time.time() < end:
                last = s.json("job", job)
                if last["state"] == "requeued":
                    break
                time.sleep(0.3)
            assert last["state"] == "requeued" and "NODE_FAIL" in last["reason"], last
            assert c.scontrol_job(first)["JobState"] == "NODE_FAIL"
        finally:
            # The test cluster's ReturnToService=2 brings the node back at slurmd's next registration; resume it in case.
            subprocess.run(["scontrol", "update", "NodeName=" + NODE, "State=RESUME"], capture_output=True, env=e2e.ENV)
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"}, timeout=180)
        assert final["state"] == "succeeded" and final["attempts"] == 2, final
        assert "resumed from its checkpoint at step" in open(s.worker_log(job, 2)).read()
        e2e.assert_same_as_run(s, job, scene)
    finally:
        s.close()


def gres(c):
    gpu = Cluster(cpus=4, gpus=2)  # its SLURM_CONF now, for the stack started below
    s = None
    try:
        s = SlurmStack(["--particles-per-gpu", "200", "--slurm-gpu-memory", "80"])
        end, nodes = time.time() + 30, []
        while time.time() < end:
            r = s.cli("nodes", "--json", check=False)
            nodes = json.loads(r.stdout) if r.returncode == 0 else []
            if nodes and len(nodes[0]["devices"]) == 2:
                break
            time.sleep(0.3)
        devs = nodes[0]["devices"]
        assert [d["kind"] for d in devs] == ["gpu", "gpu"] and devs[0]["name"] == "GPU (Slurm GRES)", nodes
        assert devs[0]["memory_total_bytes"] == 80 << 30, devs
        job = s.submit(e2e.SCENE)  # 400 particles at 200 a GPU: two ranks, one GPU each
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"}, timeout=120)
        sid = final["slurm_job_id"]
        info = gpu.scontrol_job(sid)
        assert info["NumTasks"] == "2", info
        # Slurm's GRES=gpu(IDX:0-1), read while it ran (a job that failed between two polls has no record of them).
        kinds = sorted((d["kind"], d["index"]) for d in final["devices"])
        assert kinds in ([("gpu", 0), ("gpu", 1)], []), final
        script = open(os.path.join(s.dir, "slurm", job + "-1.sbatch")).read()
        assert "'--devices' 'slurm:gpu'" in script, script
        print("gres: %s: %s" % (final["state"], final["reason"]), flush=True)
        if final["state"] == "failed":  # no GPU here: the worker's own words, not srun's summary
            assert "CUDA" in final["reason"] or "GPU" in final["reason"], final
            assert final["attempts"] == 1, final  # its own error: not requeued
        else:
            assert final["state"] == "succeeded", final
    finally:
        if s:
            s.close()
        gpu.close()
        e2e.ENV["SLURM_CONF"] = os.environ["SLURM_CONF"] = c.conf


def restart(c):
    s = SlurmStack()
    try:
        wait_slurm_nodes(s)
        scene = e2e.write_resume_scene(s)
        job = s.submit(scene)
        s.wait_state(job, {"running"}, timeout=60)
        sid = s.json("job", job)["slurm_job_id"]
        s.kill("manager")
        time.sleep(1)
        s.start_manager()
        wait_slurm_nodes(s)
        j = s.json("job", job)
        assert j["state"] in ("running", "succeeded") and j["slurm_job_id"] == sid, j
        final = s.wait_state(job, {"succeeded", "failed", "cancelled"}, timeout=180)
        assert final["state"] == "succeeded" and final["attempts"] == 1, final
    finally:
        s.close()


SCENARIOS = [equivalence, pending, killstep, nodefail, gres, restart]

if __name__ == "__main__":
    if not shutil.which("slurmctld") or not shutil.which("munged"):
        print("SKIP: slurm-wlm or munge is not installed (deploy/install-deps.sh installs them)")
        sys.exit(77)
    wanted = sys.argv[3:] or [f.__name__ for f in SCENARIOS]
    cluster = Cluster()
    failed = []
    try:
        for f in SCENARIOS:
            if f.__name__ not in wanted:
                continue
            t0 = time.time()
            try:
                f(cluster)
                print("PASS %-12s %.1f s" % (f.__name__, time.time() - t0), flush=True)
            except Exception as e:  # report and go on with the next scenario
                failed.append(f.__name__)
                print("FAIL %-12s %.1f s: %r" % (f.__name__, time.time() - t0, e), flush=True)
                traceback.print_exc()
    finally:
        cluster.close()
    sys.exit(1 if failed else 0)
