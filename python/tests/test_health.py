"""gRPC's conventions seen from Python through the package's own stubs (grpc_std): the manager's health per service
and its flip when the back-end stops, and reflection listing every pflow service. Its own stack: it stops a service."""
import time

import grpc
import pytest

from conftest import Stack


@pytest.fixture(scope="module")
def own_stack():
    s = Stack()
    yield s
    s.close()


def channel(s, name):
    with open(s.ca, "rb") as f:
        return grpc.secure_channel(s.addr(name), grpc.ssl_channel_credentials(root_certificates=f.read()))


def status(s, name, service):
    from grpc_std.health.v1 import health_pb2, health_pb2_grpc

    with channel(s, name) as ch:
        try:
            return health_pb2.HealthCheckResponse.ServingStatus.Name(
                health_pb2_grpc.HealthStub(ch).Check(health_pb2.HealthCheckRequest(service=service), timeout=2).status)
        except grpc.RpcError as e:
            return e.code().name


def wait(s, name, service, want, timeout=20):
    end, last = time.time() + timeout, None
    while time.time() < end:
        last = status(s, name, service)
        if last == want:
            return
        time.sleep(0.2)
    raise AssertionError("%s %s: %s, not %s" % (name, service, last, want))


def test_health_flips_with_the_back_end(own_stack):
    s = own_stack
    wait(s, "manager", "pflow.manager.v1.ManagerService", "SERVING")
    s.stop("backend")
    wait(s, "manager", "pflow.manager.v1.ManagerService", "NOT_SERVING")
    assert status(s, "manager", "") == "SERVING"
    s.start("backend")
    wait(s, "manager", "pflow.manager.v1.ManagerService", "SERVING")


def test_reflection_lists_every_service(own_stack):
    from grpc_std.reflection.v1alpha import reflection_pb2, reflection_pb2_grpc

    want = {"manager": {"pflow.manager.v1.ManagerService", "pflow.manager.v1.NodeRegistry"},
            "backend": {"pflow.backend.v1.SnapshotService"}, "frontend": {"pflow.frontend.v1.FrontendService"},
            "agent": {"pflow.agent.v1.AgentService"}}
    for name, services in want.items():
        with channel(own_stack, name) as ch:
            stub = reflection_pb2_grpc.ServerReflectionStub(ch)
            resp = next(iter(stub.ServerReflectionInfo(iter([reflection_pb2.ServerReflectionRequest(list_services="")]), timeout=5)))
        listed = {x.name for x in resp.list_services_response.service}
        assert services | {"grpc.health.v1.Health"} <= listed, (name, listed)
