#!/usr/bin/python3
"""Chaos over the services (issue 18; docs/operations.md, "What survives what").

The local stack with two node agents runs JOBS jobs (the service scene for 0.4 s, a checkpoint every 0.05 s of
simulated time) while, at random moments (a fixed seed: a failure can be replayed), workers are SIGKILLed and the
agents, the manager and the back-end are SIGKILLed and started again. At the end every job must be SUCCEEDED, and
every snapshot of every job (read from the back-end's files) must equal the same snapshot of an undisturbed
`pflow run` of the scene, bit for bit: a fault costs at most the work since the last checkpoint, never a result.
Prints the faults, then a table: jobs, kills by target, requeues, attempts that resumed from a checkpoint or started
over, snapshots compared, snapshots missing or different (must be 0).

  chaos_test.py BIN_DIR SRC_DIR [SECONDS [SEED [JOBS]]]      (deploy/test.sh: 120 s; longer by argument)
"""
import collections
import json
import os
import random
import re
import subprocess
import sys
import time

import h5py
import numpy as np

BIN, SRC = sys.argv[1], sys.argv[2]
SECONDS = float(sys.argv[3]) if len(sys.argv) > 3 else 120
SEED = int(sys.argv[4]) if len(sys.argv) > 4 else 18
JOBS = int(sys.argv[5]) if len(sys.argv) > 5 else 20
sys.argv = sys.argv[:3]  # e2e_test reads BIN and SRC from its argv
sys.path.insert(0, os.path.join(SRC, "tests", "services"))
import e2e_test as e2e  # noqa: E402

FINAL = {"succeeded", "failed", "cancelled"}


def workers_of(job):
    out = subprocess.run(["pgrep", "-f", "pflow-worker --job-id %s" % job], capture_output=True, text=True).stdout.split()
    return [int(p) for p in out]


def jobs_state(s, jobs):
    """{job: state}, or None while the manager does not answer (it may be down)."""
    r = s.cli("jobs", "--all", "--json", check=False)
    if r.returncode != 0:
        return None
    return {j["id"]: j["state"] for j in json.loads(r.stdout) if j["id"] in jobs}


def restart(s, name, start, rng):
    s.kill(name)
    time.sleep(rng.uniform(0.2, 1.5))
    start()


def compare(s, job, ref):
    """(snapshots compared, snapshots missing or different) of the job's back-end file against the reference."""
    path = os.path.join(s.dir, "snapshots", job + ".h5")
    bad = 0
    with h5py.File(path, "r") as a, h5py.File(ref, "r") as b:
        steps = sorted(b["snapshots"], key=int)
        for step in steps:
            if step not in a["snapshots"]:
                print("  %s: snapshot %s missing" % (job, step))
                bad += 1
                continue
            ga, gb = a["snapshots"][step], b["snapshots"][step]
            oa, ob = np.argsort(ga["id"][...]), np.argsort(gb["id"][...])
            for field in ("position", "velocity"):
                if not np.array_equal(ga[field][...][oa], gb[field][...][ob]):
                    print("  %s: snapshot %s: %s differs" % (job, step, field))
                    bad += 1
                    break
        extra = set(a["snapshots"]) - set(steps)
        if extra:
            print("  %s: snapshots not in the undisturbed run: %s" % (job, sorted(extra, key=int)))
            bad += len(extra)
    return len(steps), bad


def main():
    rng = random.Random(SEED)
    host_b = "127.0.0.2" if e2e.can_bind("127.0.0.2") else "127.0.0.1"
    agents = (("node-a", "127.0.0.1"), ("node-b", host_b))
    s = e2e.Stack(agents=agents, manager_args=["--max-attempts", "50"])
    kills = collections.Counter()
    events = []
    try:
        scene = e2e.write_resume_scene(s)
        jobs = [s.submit(scene, "--wait") for _ in range(JOBS)]
        start = time.time()
        while time.time() - start < SECONDS:
            time.sleep(rng.uniform(0.5, 2.0))
            states = jobs_state(s, jobs)
            if states is not None and all(st in FINAL for st in states.values()):
                break
            what = rng.choice(["worker", "worker", "worker", "agent", "manager", "backend"])
            t = "%6.1f s" % (time.time() - start)
            if what == "worker":
                live = [j for j in jobs if workers_of(j)]
                if not live:
                    continue
                job = rng.choice(live)
                for pid in workers_of(job):
                    try:
                        os.kill(pid, 9)
                    except ProcessLookupError:
                        pass
                events.append("%s SIGKILL the worker of %s" % (t, job))
            elif what == "agent":
                node, host = rng.choice(agents)
                restart(s, "agent-" + node, lambda: s.start_agent(node, host), rng)
                events.append("%s SIGKILL the agent of %s, started again" % (t, node))
            elif what == "manager":
                restart(s, "manager", s.start_manager, rng)
                events.append("%s SIGKILL the manager, started again" % t)
            else:
                restart(s, "backend", s.start_backend, rng)
                events.append("%s SIGKILL the back-end, started again" % t)
            kills[what] += 1
        for e in events:
            print(e)
        print("faults over; waiting for the jobs to end")
        finals = [s.wait_state(j, FINAL, timeout=900) for j in jobs]
        ref = os.path.join(s.dir, "reference.h5")
        subprocess.run([e2e.PFLOW, "run", scene, "-o", ref, "--progress", "0"], check=True, capture_output=True, env=e2e.ENV)
        resumed = started_over = compared = bad = 0
        for f in finals:
            log = "".join(open(os.path.join(s.dir, "agent-" + n, f["id"] + ".log")).read()
                          for n, _ in agents if os.path.exists(os.path.join(s.dir, "agent-" + n, f["id"] + ".log")))
            resumed += len(re.findall("resumed from its checkpoint", log))
            started_over += len(re.findall("this attempt starts from the scene's start", log))
            if f["state"] == "succeeded":
                c, b = compare(s, f["id"], ref)
                compared += c
                bad += b
        failed = [f for f in finals if f["state"] != "succeeded"]
        requeues = sum(f["attempts"] - 1 for f in finals)
        print()
        print("| jobs | succeeded | kills: workers | agents | manager | back-end | requeues | resumed from a checkpoint "
              "| started over | snapshots compared | missing or different |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        print("| %d | %d | %d | %d | %d | %d | %d | %d | %d | %d | %d |" % (
            len(jobs), len(jobs) - len(failed), kills["worker"], kills["agent"], kills["manager"], kills["backend"], requeues,
            resumed, started_over, compared, bad))
        for f in failed:
            print("%s: %s after %d attempt(s): %s" % (f["id"], f["state"], f["attempts"], f["reason"]))
        assert not failed, "jobs did not succeed"
        assert bad == 0, "snapshots missing or different"
        print("PASS chaos: %d faults, %d jobs, every snapshot identical to an undisturbed run" % (len(events), len(jobs)))
    except BaseException:
        # What CI shows of a failure is this output: the faults so far and the end of every service's log.
        print("chaos failed after these faults:\n  " + "\n  ".join(events))
        for name in sorted(os.listdir(os.path.join(s.dir, "logs"))):
            with open(os.path.join(s.dir, "logs", name), errors="replace") as f:
                print("--- the end of %s\n%s" % (name, "".join(f.readlines()[-15:])))
        raise
    finally:
        s.close()


if __name__ == "__main__":
    main()
