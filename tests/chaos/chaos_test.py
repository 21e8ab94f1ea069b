#!/usr/bin/python3
"""Chaos over the services (issue 18): jobs run while workers are SIGKILLed, the node agent is SIGKILLed and started
again, and the back-end is SIGKILLed and started again, at random moments (a fixed seed, so a failure can be
replayed). Every job must still succeed, and each one's last snapshot must equal an uninterrupted `pflow run` of
the scene bit for bit: a fault costs at most the work since the last checkpoint, never the result.

  chaos_test.py BIN_DIR SRC_DIR [SECONDS [SEED]]
"""
import os
import random
import subprocess
import sys
import time

BIN, SRC = sys.argv[1], sys.argv[2]
SECONDS = float(sys.argv[3]) if len(sys.argv) > 3 else 25
SEED = int(sys.argv[4]) if len(sys.argv) > 4 else 18
sys.argv = sys.argv[:3]  # e2e_test reads BIN and SRC from its argv
sys.path.insert(0, os.path.join(SRC, "tests", "services"))
import e2e_test as e2e  # noqa: E402


def running_workers(job):
    out = subprocess.run(["pgrep", "-f", "pflow-worker --job-id %s" % job], capture_output=True, text=True).stdout.split()
    return [int(p) for p in out]


def main():
    rng = random.Random(SEED)
    s = e2e.Stack(manager_args=["--max-attempts", "20"], cpu_slots=2)
    events = []
    try:
        scene = e2e.write_resume_scene(s)
        jobs = [s.submit(scene) for _ in range(3)]  # two run at once, the third waits
        start = time.time()
        while time.time() - start < SECONDS:
            time.sleep(rng.uniform(0.8, 2.0))
            states = {j: s.json("job", j)["state"] for j in jobs}
            if all(st in ("succeeded", "failed", "cancelled") for st in states.values()):
                break
            what = rng.choice(["worker", "worker", "agent", "backend"])
            t = "%5.1f s" % (time.time() - start)
            if what == "worker":
                live = [j for j in jobs if running_workers(j)]
                if not live:
                    continue
                job = rng.choice(live)
                for pid in running_workers(job):
                    try:
                        os.kill(pid, 9)
                    except ProcessLookupError:
                        pass
                events.append("%s SIGKILL the worker of %s" % (t, job))
            elif what == "agent":
                s.kill("agent-node-a")
                time.sleep(rng.uniform(0.2, 1.5))
                s.start_agent("node-a", "127.0.0.1")
                events.append("%s SIGKILL the agent, started again" % t)
            else:
                s.kill("backend")
                time.sleep(rng.uniform(0.2, 2.0))
                s.start("backend", [os.path.join(BIN, "pflow-backend"), "--listen", s.addr("backend"), "--data",
                                    os.path.join(s.dir, "snapshots")])
                events.append("%s SIGKILL the back-end, started again" % t)
        for e in events:
            print(e)
        finals = [s.wait_state(j, {"succeeded", "failed", "cancelled"}, timeout=600) for j in jobs]
        for f in finals:
            print("%s: %s after %d attempt(s)%s" % (f["id"], f["state"], f["attempts"], (": " + f["reason"]) if f["reason"] else ""))
        for f in finals:
            assert f["state"] == "succeeded", f
        for j in jobs:
            e2e.assert_same_as_run(s, j, scene)
        print("PASS chaos: %d faults, %d jobs identical to an uninterrupted run" % (len(events), len(jobs)))
    finally:
        s.close()


if __name__ == "__main__":
    main()
