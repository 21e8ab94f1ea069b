// Unit tests of the Agent domain class: lease validation, start/stop, heartbeat payload and replies, exit reports
// with retries. No network: a fake probe, a fake registry client, /bin/sh scripts as workers.
#include "manager/agent/Agent.h"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>

#include "tests/agent/AgentTestUtil.h"

namespace pflow::agent {
namespace {

using testing::TempDir;
using testing::waitUntil;

class FakeProbe final : public DeviceProbe {
 public:
  explicit FakeProbe(std::vector<DeviceInfo> devices) : m_devices(std::move(devices)) {}
  std::vector<DeviceInfo> probe() override { return m_devices; }
  std::string describe() const override { return "fake"; }

 private:
  std::vector<DeviceInfo> m_devices;
};

std::vector<DeviceInfo> twoGpus() {
  DeviceInfo a{DeviceKind::kGpu, 0, "Fake GPU", 80ull << 30, 1ull << 30, 0.5, 40};
  DeviceInfo b = a;
  b.index = 1;
  return {a, b};
}

class FakeRegistry final : public RegistryClient {
 public:
  Result<HeartbeatReply> heartbeat(const HeartbeatPayload& payload) override {
    std::lock_guard lock(mutex);
    heartbeats.push_back(payload);
    if (heartbeatDown) return unavailable("manager down");
    HeartbeatReply r = reply;
    reply.stopJobs.clear();
    return r;
  }
  Status reportJobExit(const JobExitReport& report) override {
    std::lock_guard lock(mutex);
    ++exitAttempts;
    if (exitFailures > 0) {
      --exitFailures;
      return unavailable("manager restarting");
    }
    if (refuseExits) return notFound("unknown job " + report.jobId);
    exits.push_back(report);
    return Status::ok();
  }
  std::size_t exitCount() {
    std::lock_guard lock(mutex);
    return exits.size();
  }

  std::mutex mutex;
  std::vector<HeartbeatPayload> heartbeats;
  std::vector<JobExitReport> exits;
  HeartbeatReply reply;
  bool heartbeatDown = false;
  int exitFailures = 0;
  int exitAttempts = 0;
  bool refuseExits = false;
};

class AgentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    m_worker = testing::writeScript(m_dir / "worker.sh",
                                    "trap 'echo stopping; exit 0' TERM\n"
                                    "echo \"args $*\"\n"
                                    "case \"$*\" in *fail*) echo 'error: cannot open model' >&2; exit 2;; esac\n"
                                    "echo ready\n"
                                    "while :; do sleep 0.05; done");
    m_registry = std::make_shared<FakeRegistry>();
    m_agent = makeAgent(m_registry);
  }
  std::unique_ptr<Agent> makeAgent(std::shared_ptr<RegistryClient> registry) {
    AgentOptions o;
    o.node = "node-a";
    o.advertiseAddress = "127.0.0.1:50061";
    o.heartbeatIntervalSeconds = 0.05;
    o.retryInitialSeconds = 0.02;
    o.retryMaxSeconds = 0.1;
    o.launch.workdir = m_dir.path();
    o.launch.workerPath = m_worker;
    o.launch.mpirun = "";
    o.launch.graceSeconds = 1;
    return std::make_unique<Agent>(o, std::make_unique<FakeProbe>(twoGpus()), std::move(registry));
  }
  Lease lease(const std::string& id, std::vector<DeviceRef> devices = {{"node-a", DeviceKind::kGpu, 0}}) {
    Lease l;
    l.jobId = id;
    l.modelUri = "file:///models/" + id;
    l.devices = std::move(devices);
    return l;
  }
  bool waitReady(const std::string& id) {
    return waitUntil([&] { return testing::readFile(m_dir / (id + ".log")).find("ready") != std::string::npos; }, 10);
  }

  TempDir m_dir;
  std::string m_worker;
  std::shared_ptr<FakeRegistry> m_registry;
  std::unique_ptr<Agent> m_agent;
};

TEST_F(AgentTest, RejectsBadLeasesWithEveryProblem) {
  Lease l;
  l.jobId = "../etc/passwd";
  l.devices = {{"node-a", DeviceKind::kGpu, 0},
               {"node-a", DeviceKind::kGpu, 0},
               {"node-a", DeviceKind::kGpu, 5},
               {"node-z", DeviceKind::kGpu, 0},
               {"node-a", DeviceKind::kCpu, 0},
               {"", DeviceKind::kGpu, 0},
               {"node-a", DeviceKind::kGpu, -1}};
  auto r = m_agent->startJob(l);
  ASSERT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  const std::string& m = r.status().message();
  for (const char* expected : {"lease.job_id", "lease.model_uri: empty", "lease.devices[1]: node-a:gpu:0 is listed twice",
                               "lease.devices[2]: node-a:gpu:5: this node has no such device",
                               "lease.devices[3].node: 'node-z' is not this node (node-a) and has no entry in node_hosts",
                               "lease.devices[4].kind: a lease uses one device kind",
                               "lease.devices[5].node: empty", "lease.devices[6].index: negative"}) {
    EXPECT_NE(m.find(expected), std::string::npos) << "missing '" << expected << "' in:\n" << m;
  }
  EXPECT_EQ(m_agent->startJob(lease("empty", {})).status().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(m_agent->runningJobs().empty());
}

TEST_F(AgentTest, JobIdRules) {
  EXPECT_TRUE(isValidJobId("job-42.run_1"));
  EXPECT_FALSE(isValidJobId(""));
  EXPECT_FALSE(isValidJobId(".hidden"));
  EXPECT_FALSE(isValidJobId("-x"));
  EXPECT_FALSE(isValidJobId("a/b"));
  EXPECT_FALSE(isValidJobId("a b"));
  EXPECT_FALSE(isValidJobId(std::string(129, 'a')));
}

TEST_F(AgentTest, StartStopAndDuplicates) {
  auto pid = m_agent->startJob(lease("j1"));
  ASSERT_TRUE(pid) << pid.status().toString();
  ASSERT_TRUE(waitReady("j1"));
  EXPECT_EQ(m_agent->runningJobs(), std::vector<std::string>{"j1"});
  EXPECT_EQ(m_agent->startJob(lease("j1", {{"node-a", DeviceKind::kGpu, 1}})).status().code(), StatusCode::kAlreadyExists);
  // GPU 0 is busy with j1.
  auto busy = m_agent->startJob(lease("j2"));
  EXPECT_EQ(busy.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(busy.status().message().find("busy with job j1"), std::string::npos);

  const auto devices = m_agent->devices();
  ASSERT_EQ(devices.size(), 2u);
  EXPECT_EQ(devices[0].jobId, "j1");
  EXPECT_EQ(devices[1].jobId, "");

  EXPECT_EQ(m_agent->stopJob("nope").code(), StatusCode::kNotFound);
  ASSERT_TRUE(m_agent->stopJob("j1").isOk());
  ASSERT_TRUE(waitUntil([&] { return m_registry->exitCount() == 1; }, 10));
  EXPECT_EQ(m_registry->exits[0].jobId, "j1");
  EXPECT_EQ(m_registry->exits[0].node, "node-a");
  EXPECT_EQ(m_registry->exits[0].exitCode, 0);
  EXPECT_EQ(m_registry->exits[0].reason, "stopped: SIGTERM");
  EXPECT_TRUE(waitUntil([&] { return m_agent->runningJobs().empty(); }, 5));
  EXPECT_EQ(m_agent->devices()[0].jobId, "");
  // GPU 0 is free again.
  EXPECT_TRUE(m_agent->startJob(lease("j2")));
}

TEST_F(AgentTest, MissingWorkerIsAFailedPrecondition) {
  AgentOptions o = m_agent->options();
  o.launch.workerPath = m_dir / "no-such-worker";
  Agent agent(o, std::make_unique<FakeProbe>(twoGpus()), nullptr);
  auto r = agent.startJob(lease("j"));
  EXPECT_EQ(r.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(r.status().message().find("no-such-worker"), std::string::npos);
}

TEST_F(AgentTest, FailedWorkerIsReportedWithItsErrorLine) {
  Lease l = lease("fail-1");
  ASSERT_TRUE(m_agent->startJob(l));
  ASSERT_TRUE(waitUntil([&] { return m_registry->exitCount() == 1; }, 10));
  EXPECT_EQ(m_registry->exits[0].exitCode, 2);
  EXPECT_EQ(m_registry->exits[0].reason, "error: cannot open model");
}

TEST_F(AgentTest, HeartbeatPayloadAndStopJobs) {
  ASSERT_TRUE(m_agent->startJob(lease("j1")));
  ASSERT_TRUE(waitReady("j1"));
  const HeartbeatPayload p = m_agent->heartbeatPayload();
  EXPECT_EQ(p.node, "node-a");
  EXPECT_EQ(p.agentAddress, "127.0.0.1:50061");
  ASSERT_EQ(p.devices.size(), 2u);
  EXPECT_EQ(p.devices[1].name, "Fake GPU");
  EXPECT_EQ(p.runningJobs, std::vector<std::string>{"j1"});

  m_registry->reply.intervalSeconds = 0.5;
  m_registry->reply.stopJobs = {"j1", "not-here"};
  ASSERT_TRUE(m_agent->heartbeatOnce().isOk());
  EXPECT_DOUBLE_EQ(m_agent->heartbeatInterval(), 0.5);
  ASSERT_TRUE(waitUntil([&] { return m_registry->exitCount() == 1; }, 10));
  EXPECT_EQ(m_registry->exits[0].reason, "stopped: SIGTERM");
}

TEST_F(AgentTest, HeartbeatThreadKeepsGoingWhileTheManagerIsDown) {
  m_registry->heartbeatDown = true;
  m_agent->startHeartbeats();
  ASSERT_TRUE(waitUntil([&] { std::lock_guard l(m_registry->mutex); return m_registry->heartbeats.size() >= 3; }, 10));
  m_registry->heartbeatDown = false;
  const std::size_t before = [&] { std::lock_guard l(m_registry->mutex); return m_registry->heartbeats.size(); }();
  ASSERT_TRUE(waitUntil([&] { std::lock_guard l(m_registry->mutex); return m_registry->heartbeats.size() >= before + 2; }, 10));
  m_agent->shutdown(1);
}

TEST_F(AgentTest, ExitReportsAreRetriedUntilTheManagerAnswers) {
  m_registry->exitFailures = 4;
  ASSERT_TRUE(m_agent->startJob(lease("fail-retry")));
  ASSERT_TRUE(waitUntil([&] { return m_registry->exitCount() == 1; }, 10));
  EXPECT_EQ(m_registry->exitAttempts, 5);
  EXPECT_EQ(m_registry->exits[0].jobId, "fail-retry");
  EXPECT_TRUE(m_agent->waitForReports(5));
  EXPECT_EQ(m_agent->pendingExitReports(), 0u);
}

TEST_F(AgentTest, ExitReportRefusedByTheManagerIsNotRetried) {
  m_registry->refuseExits = true;
  ASSERT_TRUE(m_agent->startJob(lease("fail-refused")));
  ASSERT_TRUE(waitUntil([&] { std::lock_guard l(m_registry->mutex); return m_registry->exitAttempts >= 1; }, 10));
  EXPECT_TRUE(m_agent->waitForReports(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::lock_guard l(m_registry->mutex);
  EXPECT_EQ(m_registry->exitAttempts, 1);
}

TEST_F(AgentTest, ShutdownStopsWorkersAndFlushesReports) {
  ASSERT_TRUE(m_agent->startJob(lease("j1")));
  ASSERT_TRUE(m_agent->startJob(lease("j2", {{"node-a", DeviceKind::kGpu, 1}})));
  ASSERT_TRUE(waitReady("j1"));
  ASSERT_TRUE(waitReady("j2"));
  m_agent->shutdown(5);
  EXPECT_TRUE(m_agent->runningJobs().empty());
  EXPECT_EQ(m_registry->exitCount(), 2u);
  EXPECT_EQ(m_agent->startJob(lease("j3")).status().code(), StatusCode::kUnavailable);
}

TEST(TransientErrors, OnlyUnansweredCallsAreRetried) {
  EXPECT_TRUE(isTransient(unavailable("x")));
  EXPECT_TRUE(isTransient(Status(StatusCode::kDeadlineExceeded, "x")));
  EXPECT_FALSE(isTransient(notFound("x")));
  EXPECT_FALSE(isTransient(invalidArgument("x")));
}

}  // namespace
}  // namespace pflow::agent
