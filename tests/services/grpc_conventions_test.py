#!/usr/bin/python3
"""gRPC's conventions on every pflow server (issue 24), from a generic client's side: the frontend, the back-end, the
manager and a node agent as processes on loopback (plaintext), probed with gRPC's standard health and reflection
protocols through stubs generated from proto/ at build time (build/python), the way grpcurl or an orchestrator
would.

  health      every server's "" and each of its services SERVING; an unknown service NOT_FOUND; the manager's
              services NOT_SERVING within seconds of the back-end's stop (its "" stays SERVING: the server itself is
              up), SERVING again once the back-end is back; the back-end's service NOT_SERVING while the manager is down
  drain       a health Watch on the manager sees NOT_SERVING when the manager is told to stop (SIGTERM), before its
              stream ends
  reflection  each server lists its pflow service(s), grpc.health.v1.Health and the reflection service, and serves the
              file descriptor of its service (its methods by name)
Usage: grpc_conventions_test.py BIN_DIR SRC_DIR BUILD_DIR; exit code 77 (skipped) without python3-grpcio.
"""
import os
import signal
import subprocess
import sys
import tempfile
import time
import traceback

BIN, SRC, BUILD = sys.argv[1], sys.argv[2], sys.argv[3]
try:
    import grpc
except ImportError:
    print("SKIP: python3-grpcio is not installed")
    sys.exit(77)
sys.path.insert(0, os.path.join(BUILD, "python"))
from google.protobuf import descriptor_pb2  # noqa: E402
from grpc_std.health.v1 import health_pb2, health_pb2_grpc  # noqa: E402
from grpc_std.reflection.v1alpha import reflection_pb2, reflection_pb2_grpc  # noqa: E402
from ports import free_port  # noqa: E402  (tests/services/ports.py, beside this file)

ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
SERVING = health_pb2.HealthCheckResponse.SERVING
NOT_SERVING = health_pb2.HealthCheckResponse.NOT_SERVING


class Stack:
    def __init__(self):
        self.dir = tempfile.mkdtemp(prefix="pflow-grpc-")
        self.ports = {k: free_port() for k in ("frontend", "backend", "manager", "agent")}
        self.procs = {}
        self.start("frontend")
        self.start("backend")
        self.start("manager")
        self.start("agent")
        for name in self.ports:
            self.wait_up(name)

    def addr(self, name):
        return "127.0.0.1:%d" % self.ports[name]

    def command(self, name):
        b = lambda p: os.path.join(BIN, p)  # noqa: E731
        return {
            "frontend": [b("pflow-frontend"), "--listen", self.addr("frontend"), "--models", os.path.join(self.dir, "models"), "--insecure"],
            "backend": [b("pflow-backend"), "--listen", self.addr("backend"), "--data", os.path.join(self.dir, "data"), "--manager",
                        self.addr("manager"), "--insecure"],
            "manager": [b("pflow-manager"), "--listen", self.addr("manager"), "--db", os.path.join(self.dir, "m.db"), "--frontend",
                        self.addr("frontend"), "--backend", self.addr("backend"), "--insecure"],
            "agent": [b("pflow-agent"), "--node", "n1", "--listen", self.addr("agent"), "--manager", self.addr("manager"), "--workdir",
                      os.path.join(self.dir, "agent"), "--worker", b("pflow-worker"), "--cpu-slots", "1", "--force-cpu", "--insecure"],
        }[name]

    def start(self, name):
        log = open(os.path.join(self.dir, name + ".log"), "ab")
        self.procs[name] = subprocess.Popen(self.command(name), stdout=log, stderr=subprocess.STDOUT, env=ENV, start_new_session=True)

    def stop(self, name):
        p = self.procs.pop(name)
        os.killpg(p.pid, signal.SIGTERM)
        p.wait(timeout=30)

    def wait_up(self, name, timeout=30):
        end = time.time() + timeout
        while time.time() < end:
            try:
                if check(self.addr(name), "") == SERVING:
                    return
            except grpc.RpcError:
                pass
            time.sleep(0.1)
        raise AssertionError("%s did not come up; logs in %s" % (name, self.dir))

    def close(self):
        for name in list(self.procs):
            try:
                self.stop(name)
            except Exception:
                pass


def check(address, service, timeout=2):
    with grpc.insecure_channel(address) as ch:
        return health_pb2_grpc.HealthStub(ch).Check(health_pb2.HealthCheckRequest(service=service), timeout=timeout).status


def wait_status(address, service, want, timeout=20):
    end, last = time.time() + timeout, None
    while time.time() < end:
        try:
            last = check(address, service)
        except grpc.RpcError as e:
            last = e.code()
        if last == want:
            return
        time.sleep(0.2)
    raise AssertionError("%s %r: %r, not %r after %d s" % (address, service, last, want, timeout))


SERVICES = {
    "frontend": ["pflow.frontend.v1.FrontendService"],
    "backend": ["pflow.backend.v1.SnapshotService"],
    "manager": ["pflow.manager.v1.ManagerService", "pflow.manager.v1.NodeRegistry"],
    "agent": ["pflow.agent.v1.AgentService"],
}


def health(s):
    for name, services in SERVICES.items():
        for svc in [""] + services:
            wait_status(s.addr(name), svc, SERVING)
    try:
        check(s.addr("manager"), "pflow.nosuch.v1.Service")
        raise AssertionError("an unknown service answered")
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.NOT_FOUND, e.code()
    s.stop("backend")
    for svc in SERVICES["manager"]:
        wait_status(s.addr("manager"), svc, NOT_SERVING)
    assert check(s.addr("manager"), "") == SERVING  # the manager itself is up
    s.start("backend")
    s.wait_up("backend")
    for svc in SERVICES["manager"]:
        wait_status(s.addr("manager"), svc, SERVING)
    s.stop("manager")
    wait_status(s.addr("backend"), "pflow.backend.v1.SnapshotService", NOT_SERVING)
    wait_status(s.addr("agent"), "pflow.agent.v1.AgentService", NOT_SERVING)
    s.start("manager")
    s.wait_up("manager")
    wait_status(s.addr("backend"), "pflow.backend.v1.SnapshotService", SERVING)
    for svc in SERVICES["manager"]:  # the two depend on each other: neither holds the other down
        wait_status(s.addr("manager"), svc, SERVING)


def reflect(address, request):
    with grpc.insecure_channel(address) as ch:
        stub = reflection_pb2_grpc.ServerReflectionStub(ch)
        return next(iter(stub.ServerReflectionInfo(iter([request]), timeout=5)))


def reflection(s):
    for name, services in SERVICES.items():
        resp = reflect(s.addr(name), reflection_pb2.ServerReflectionRequest(list_services=""))
        listed = {x.name for x in resp.list_services_response.service}
        want = set(services) | {"grpc.health.v1.Health", "grpc.reflection.v1alpha.ServerReflection"}
        assert want <= listed, (name, listed)
        for svc in services:
            resp = reflect(s.addr(name), reflection_pb2.ServerReflectionRequest(file_containing_symbol=svc))
            files = [descriptor_pb2.FileDescriptorProto.FromString(b) for b in resp.file_descriptor_response.file_descriptor_proto]
            assert files, (name, svc, resp)
            methods = {m.name for f in files for sv in f.service if f.package + "." + sv.name == svc for m in sv.method}
            assert methods, (name, svc, [f.name for f in files])
    methods = {m.name for f in [descriptor_pb2.FileDescriptorProto.FromString(b) for b in reflect(
        s.addr("manager"), reflection_pb2.ServerReflectionRequest(file_containing_symbol="pflow.manager.v1.ManagerService"))
        .file_descriptor_response.file_descriptor_proto] for sv in f.service for m in sv.method}
    assert {"SubmitJob", "ListJobs", "CancelJob", "WatchJob", "ListNodes"} <= methods, methods


def drain(s):
    with grpc.insecure_channel(s.addr("manager")) as ch:
        stream = health_pb2_grpc.HealthStub(ch).Watch(health_pb2.HealthCheckRequest(service=""), timeout=30)
        seen = [next(stream).status]
        assert seen == [SERVING], seen
        os.killpg(s.procs["manager"].pid, signal.SIGTERM)
        try:
            for resp in stream:
                seen.append(resp.status)
                if resp.status == NOT_SERVING:
                    break
        except grpc.RpcError:
            pass  # the stream ended with the server
        assert NOT_SERVING in seen, seen
    s.procs.pop("manager").wait(timeout=30)


SCENARIOS = [reflection, health, drain]

if __name__ == "__main__":
    wanted = sys.argv[4:] or [f.__name__ for f in SCENARIOS]
    failed = []
    for f in SCENARIOS:
        if f.__name__ not in wanted:
            continue
        s = Stack()
        t0 = time.time()
        try:
            f(s)
            print("PASS %-12s %.1f s" % (f.__name__, time.time() - t0), flush=True)
        except Exception as e:
            failed.append(f.__name__)
            print("FAIL %-12s %.1f s: %r (logs in %s)" % (f.__name__, time.time() - t0, e, s.dir), flush=True)
            traceback.print_exc()
        finally:
            s.close()
    sys.exit(1 if failed else 0)
