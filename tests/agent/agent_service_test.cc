// Service tests on real sockets (127.0.0.1, port 0): AgentService StartJob/StopJob/GetDevices with a fake worker
// script, and heartbeats and exit reports reaching a fake NodeRegistry through GrpcRegistryClient.
#include "manager/agent/AgentService.h"

#include <gtest/gtest.h>

#include "common/rpc/Rpc.h"
#include "tests/agent/AgentTestUtil.h"
#include "tests/agent/FakeNodeRegistry.h"

namespace pflow::agent {
namespace {

namespace av1 = pflow::agent::v1;
namespace mv1 = pflow::manager::v1;
namespace cv1 = pflow::common::v1;
using testing::FakeNodeRegistry;
using testing::TempDir;

class AgentServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto server = rpc::ServerRunner::start("127.0.0.1:0", {&m_registry});
    ASSERT_TRUE(server) << server.status().toString();
    m_registryServer = std::move(server.value());

    const std::string worker = testing::writeScript(m_dir / "worker.sh",
                                                    "trap 'echo stopping; exit 0' TERM\n"
                                                    "echo \"args $*\"\n"
                                                    "case \"$*\" in *crash*) echo 'FATAL: bad model' >&2; exit 4;; esac\n"
                                                    "echo ready\n"
                                                    "while :; do sleep 0.05; done");
    AgentOptions o;
    o.node = "node-a";
    o.heartbeatIntervalSeconds = 0.1;
    o.retryInitialSeconds = 0.05;
    o.retryMaxSeconds = 0.2;
    o.launch.workdir = m_dir.path();
    o.launch.workerPath = worker;
    o.launch.mpirun = "";
    o.launch.graceSeconds = 2;
    auto registry = std::make_shared<GrpcRegistryClient>(m_registryServer->address(), 2, 2);
    m_agent = std::make_unique<Agent>(o, std::make_unique<CpuProbe>(2), registry);
    m_service = std::make_unique<AgentService>(*m_agent);
    auto agentServer = rpc::ServerRunner::start("127.0.0.1:0", {m_service.get()});
    ASSERT_TRUE(agentServer) << agentServer.status().toString();
    m_agentServer = std::move(agentServer.value());
    m_agent->setAdvertiseAddress(m_agentServer->address());
    m_stub = av1::AgentService::NewStub(rpc::makeChannel(m_agentServer->address()));
  }
  void TearDown() override {
    if (m_agent) m_agent->shutdown(2);
    if (m_agentServer) m_agentServer->shutdown(1);
    if (m_registryServer) m_registryServer->shutdown(1);
  }

  grpc::Status startJob(const std::string& id, int slot, av1::StartJobResponse* resp,
                        cv1::DeviceKind kind = cv1::DEVICE_KIND_CPU) {
    av1::StartJobRequest req;
    av1::Lease* l = req.mutable_lease();
    l->set_job_id(id);
    l->set_model_uri("file:///models/" + id);
    l->set_manager_address("127.0.0.1:1");
    auto* d = l->add_devices();
    d->set_node("node-a");
    d->set_index(slot);
    d->set_kind(kind);
    auto ctx = rpc::contextWithDeadline(5);
    return m_stub->StartJob(ctx.get(), req, resp);
  }
  grpc::Status stopJob(const std::string& id) {
    av1::StopJobRequest req;
    req.set_job_id(id);
    av1::StopJobResponse resp;
    auto ctx = rpc::contextWithDeadline(5);
    return m_stub->StopJob(ctx.get(), req, &resp);
  }
  av1::GetDevicesResponse devices() {
    av1::GetDevicesResponse resp;
    auto ctx = rpc::contextWithDeadline(5);
    EXPECT_TRUE(m_stub->GetDevices(ctx.get(), av1::GetDevicesRequest(), &resp).ok());
    return resp;
  }
  bool waitReady(const std::string& id) {
    return testing::waitUntil(
        [&] { return testing::readFile(m_dir / (id + ".log")).find("ready") != std::string::npos; }, 10);
  }

  TempDir m_dir;
  FakeNodeRegistry m_registry;
  std::unique_ptr<rpc::ServerRunner> m_registryServer;
  std::unique_ptr<Agent> m_agent;
  std::unique_ptr<AgentService> m_service;
  std::unique_ptr<rpc::ServerRunner> m_agentServer;
  std::unique_ptr<av1::AgentService::Stub> m_stub;
};

TEST_F(AgentServiceTest, StartGetDevicesStop) {
  av1::StartJobResponse started;
  grpc::Status s = startJob("job-1", 1, &started);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_GT(started.pid(), 0);
  ASSERT_TRUE(waitReady("job-1"));
  EXPECT_NE(testing::readFile(m_dir / "job-1.log").find("args --job-id job-1 --model file:///models/job-1 --manager "
                                                          "127.0.0.1:1 --devices node-a:cpu:1"),
            std::string::npos);

  EXPECT_EQ(startJob("job-1", 0, &started).error_code(), grpc::StatusCode::ALREADY_EXISTS);
  EXPECT_EQ(startJob("job-2", 1, &started).error_code(), grpc::StatusCode::FAILED_PRECONDITION);  // slot 1 busy
  EXPECT_EQ(startJob("job-3", 0, &started, cv1::DEVICE_KIND_UNSPECIFIED).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(startJob("job-4", 7, &started).error_code(), grpc::StatusCode::INVALID_ARGUMENT);  // no slot 7

  const auto d = devices();
  EXPECT_EQ(d.node(), "node-a");
  ASSERT_EQ(d.devices_size(), 2);
  EXPECT_EQ(d.devices(0).ref().kind(), cv1::DEVICE_KIND_CPU);
  EXPECT_EQ(d.devices(0).state(), mv1::DEVICE_STATE_FREE);
  EXPECT_EQ(d.devices(1).state(), mv1::DEVICE_STATE_BUSY);
  EXPECT_EQ(d.devices(1).job_id(), "job-1");
  EXPECT_GT(d.devices(1).memory_total_bytes(), 0u);
  EXPECT_NE(d.devices(1).name().find("CPU slot ("), std::string::npos);

  ASSERT_TRUE(stopJob("job-1").ok());
  ASSERT_TRUE(m_registry.waitFor([&] { return m_registry.exits.size() == 1; }, 10));
  const auto exit = m_registry.exitsCopy().at(0);
  EXPECT_EQ(exit.job_id(), "job-1");
  EXPECT_EQ(exit.node(), "node-a");
  EXPECT_EQ(exit.exit_code(), 0);
  EXPECT_EQ(exit.reason(), "stopped: SIGTERM");
  ASSERT_TRUE(testing::waitUntil([&] { return m_agent->runningJobs().empty(); }, 5));
  EXPECT_EQ(stopJob("job-1").error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(AgentServiceTest, HeartbeatsCarryDevicesAndJobsAndStopJobsWorks) {
  m_agent->startHeartbeats();
  ASSERT_TRUE(m_registry.waitFor([&] { return m_registry.heartbeatCount["node-a"] >= 1; }, 10));
  auto hb = m_registry.latestOf("node-a");
  EXPECT_EQ(hb.agent_address(), m_agentServer->address());
  ASSERT_EQ(hb.devices_size(), 2);
  EXPECT_EQ(hb.devices(1).ref().node(), "node-a");
  EXPECT_EQ(hb.devices(1).ref().index(), 1);
  EXPECT_EQ(hb.running_jobs_size(), 0);

  av1::StartJobResponse started;
  ASSERT_TRUE(startJob("job-hb", 0, &started).ok());
  ASSERT_TRUE(m_registry.waitFor(
      [&] { return m_registry.latest["node-a"].running_jobs_size() == 1 && m_registry.latest["node-a"].running_jobs(0) == "job-hb"; },
      10));
  ASSERT_TRUE(waitReady("job-hb"));
  m_registry.stop("node-a", "job-hb");  // the manager cancels it: the next heartbeat answer says so
  ASSERT_TRUE(m_registry.waitFor([&] { return m_registry.exits.size() == 1; }, 10));
  EXPECT_EQ(m_registry.exitsCopy().at(0).reason(), "stopped: SIGTERM");
  EXPECT_TRUE(m_registry.waitFor([&] { return m_registry.latest["node-a"].running_jobs_size() == 0; }, 10));
}

TEST_F(AgentServiceTest, ExitReportSurvivesAManagerRestart) {
  const std::string address = m_registryServer->address();
  m_registryServer->shutdown(0);  // the manager goes away
  av1::StartJobResponse started;
  ASSERT_TRUE(startJob("crash-1", 0, &started).ok());
  ASSERT_TRUE(testing::waitUntil([&] { return m_agent->runningJobs().empty(); }, 10));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a few failed attempts
  EXPECT_EQ(m_agent->pendingExitReports(), 1u);

  FakeNodeRegistry restarted;
  auto server = rpc::ServerRunner::start(address, {&restarted});  // the manager comes back on the same port
  ASSERT_TRUE(server) << server.status().toString();
  ASSERT_TRUE(restarted.waitFor([&] { return restarted.exits.size() == 1; }, 15));
  const auto exit = restarted.exitsCopy().at(0);
  EXPECT_EQ(exit.job_id(), "crash-1");
  EXPECT_EQ(exit.exit_code(), 4);
  EXPECT_EQ(exit.reason(), "FATAL: bad model");
  EXPECT_TRUE(m_agent->waitForReports(5));
  m_agent->shutdown(1);
  server.value()->shutdown(1);
}

}  // namespace
}  // namespace pflow::agent
