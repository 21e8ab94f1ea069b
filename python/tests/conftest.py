"""The real local stack for the package's tests: pflow-frontend, pflow-backend, pflow-manager and one pflow-agent (a
CPU slot) as processes on loopback over mutual TLS, as deploy/local/start.sh runs them; the package talks to them as
a user with the first admin's token. PFLOW_BIN_DIR (default: build/bin) and PFLOW_SRC_DIR (default: the checkout)."""
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import pytest

SRC = os.environ.get("PFLOW_SRC_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
BIN = os.environ.get("PFLOW_BIN_DIR", os.path.join(SRC, "build", "bin"))
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_WAIT_POLICY="passive")
for _k in ("PFLOW_TOKEN", "PFLOW_CA", "PFLOW_INSECURE", "PFLOW_CONFIG", "PFLOW_MANAGER", "PFLOW_BACKEND"):
    ENV.pop(_k, None)
    os.environ.pop(_k, None)
os.environ.setdefault("PFLOW_CLI", os.path.join(BIN, "pflow"))
sys.path.insert(0, os.path.join(SRC, "tests", "services"))
from ports import free_port  # noqa: E402  (the checkout's tests/services/ports.py, shared with the service tests)

SCENE = os.path.join(SRC, "tests/data/service_scene.yaml")
LONG = os.path.join(SRC, "tests/data/service_long_scene.yaml")


class Stack:
    def __init__(self):
        self.dir = tempfile.mkdtemp(prefix="pflow-py-")
        self.ports = {k: free_port() for k in ("manager", "frontend", "backend", "agent")}
        self.tls = os.path.join(self.dir, "tls")
        subprocess.run([os.path.join(SRC, "deploy/local/certs.sh"), self.tls, "manager", "frontend", "backend", "node:node-a"],
                       check=True, capture_output=True)
        self.procs = {}
        for name in ("frontend", "backend", "manager", "agent"):
            self.start(name)
        token = os.path.join(self.dir, "admin.token")
        end = time.time() + 30
        while not (os.path.exists(token) and os.path.getsize(token) > 0):
            assert time.time() < end, "the manager wrote no admin token; logs in " + self.dir
            time.sleep(0.05)
        self.token = open(token).read().strip()
        self.ca = os.path.join(self.tls, "ca.crt")

    def addr(self, name):
        return "127.0.0.1:%d" % self.ports[name]

    def command(self, name):
        b = lambda p: os.path.join(BIN, p)  # noqa: E731
        tls = ["--tls-dir", self.tls]
        return {
            "frontend": [b("pflow-frontend"), "--listen", self.addr("frontend"), "--models", os.path.join(self.dir, "models")] + tls,
            "backend": [b("pflow-backend"), "--listen", self.addr("backend"), "--data", os.path.join(self.dir, "data"), "--manager",
                        self.addr("manager")] + tls,
            "manager": [b("pflow-manager"), "--listen", self.addr("manager"), "--db", os.path.join(self.dir, "manager.db"),
                        "--frontend", self.addr("frontend"), "--backend", self.addr("backend"), "--heartbeat-interval", "1",
                        "--tick", "0.5", "--admin-token-file", os.path.join(self.dir, "admin.token")] + tls,
            "agent": [b("pflow-agent"), "--node", "node-a", "--listen", self.addr("agent"), "--manager", self.addr("manager"),
                      "--workdir", os.path.join(self.dir, "agent"), "--worker", b("pflow-worker"), "--cpu-slots", "1", "--force-cpu",
                      "--heartbeat-interval", "1", "--grace", "3"] + tls,
        }[name]

    def start(self, name):
        log = open(os.path.join(self.dir, name + ".log"), "ab")
        self.procs[name] = subprocess.Popen(self.command(name), stdout=log, stderr=subprocess.STDOUT, env=ENV, start_new_session=True)

    def stop(self, name):
        p = self.procs.pop(name)
        os.killpg(p.pid, signal.SIGTERM)
        p.wait(timeout=30)

    def cli(self, *args):
        env = dict(ENV, PFLOW_TOKEN=self.token, PFLOW_CA=self.ca)
        return subprocess.run([os.path.join(BIN, "pflow"), "--manager", self.addr("manager"), "--backend", self.addr("backend")] +
                              list(args), capture_output=True, text=True, env=env, check=True)

    def client(self, **kw):
        import pflow

        args = dict(manager=self.addr("manager"), backend=self.addr("backend"), token=self.token, ca=self.ca)
        args.update(kw)
        return pflow.Client(**args)

    def close(self):
        for name in list(self.procs):
            try:
                self.stop(name)
            except Exception:
                pass
        if not os.environ.get("PFLOW_E2E_KEEP"):
            shutil.rmtree(self.dir, ignore_errors=True)

    def diagnosis(self):
        """Which processes have exited, and the end of each log: what a failed start is explained by."""
        lines = []
        for name, p in self.procs.items():
            code = p.poll()
            lines.append("%s: %s" % (name, "running" if code is None else "exited with %s" % code))
            try:
                with open(os.path.join(self.dir, name + ".log"), "rb") as f:
                    tail = f.read()[-1500:].decode("utf-8", "replace")
                lines += ["  | " + line for line in tail.splitlines()[-12:]]
            except OSError:
                pass
        return "\n".join(lines)


def wait_nodes(client, timeout=60, stack=None):
    end = time.time() + timeout
    last = None
    while time.time() < end:
        try:
            nodes = client.nodes()
            if nodes and nodes[0].devices and not nodes[0].lost:
                return nodes
            last = "nodes: %r" % (nodes,)
        except Exception as e:  # the manager may not listen yet
            last = repr(e)
        if stack is not None and any(p.poll() is not None for p in stack.procs.values()):
            break
        time.sleep(0.2)
    raise AssertionError("the agent did not register (last answer: %s)\n%s" % (last, stack.diagnosis() if stack else ""))


@pytest.fixture(scope="session")
def stack():
    s = Stack()
    try:
        wait_nodes(s.client(), stack=s)
        yield s
    finally:
        s.close()
