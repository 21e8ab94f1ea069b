// The multi-node rehearsal on one machine (label mpi): Open MPI with a two-node hostfile through
// deploy/local/pflow-rsh, then two real pflow-agent processes (node-a on 127.0.0.1, node-b on 127.0.0.2)
// heartbeating to a fake manager, and a job placed across both. Skipped when mpirun is absent.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <set>

#include "common/rpc/Rpc.h"
#include "manager/agent/Supervisor.h"
#include "pflow/agent/v1/agent_service.grpc.pb.h"
#include "tests/agent/AgentTestUtil.h"
#include "tests/agent/FakeNodeRegistry.h"

namespace pflow::agent {
namespace {

namespace av1 = pflow::agent::v1;
namespace cv1 = pflow::common::v1;
using testing::FakeNodeRegistry;
using testing::TempDir;
using testing::waitUntil;

const std::string kRsh = std::string(PFLOW_SOURCE_DIR) + "/deploy/local/pflow-rsh";

bool haveMpirun() { return std::system("command -v mpirun >/dev/null 2>&1") == 0; }

// Linux routes all of 127/8 to lo; some sandboxes only have 127.0.0.1. Then node-b shares it (another port).
std::string secondLoopback() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = 0;
  ::inet_pton(AF_INET, "127.0.0.2", &a.sin_addr);
  const bool ok = fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  if (fd >= 0) ::close(fd);
  return ok ? "127.0.0.2" : "127.0.0.1";
}

std::string run(const std::string& command, int* rc) {
  std::string out;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  *rc = ::pclose(p);
  return out;
}

TEST(Rehearsal, MpirunHostfileThroughRshAgent) {
  if (!haveMpirun()) GTEST_SKIP() << "mpirun not installed";
  TempDir dir;
  testing::writeFile(dir / "hosts", "node-a slots=1\nnode-b slots=1\n");
  int rc = -1;
  // The README's command, plus which "host" each rank landed on (pflow-rsh gives each its own TMPDIR).
  const std::string out = run("env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 TMPDIR=" + dir.path() +
                                  " mpirun --hostfile " + (dir / "hosts") + " --mca plm_rsh_agent " + kRsh +
                                  " -np 2 sh -c 'echo rank $OMPI_COMM_WORLD_RANK of $OMPI_COMM_WORLD_SIZE on ${TMPDIR##*/}'",
                              &rc);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("rank 0 of 2 on node-a"), std::string::npos) << out;
  EXPECT_NE(out.find("rank 1 of 2 on node-b"), std::string::npos) << out;

  const std::string plain = run("env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 TMPDIR=" + dir.path() +
                                    " mpirun --hostfile " + (dir / "hosts") + " --mca plm_rsh_agent " + kRsh + " -np 2 hostname",
                                &rc);
  EXPECT_EQ(rc, 0) << plain;
}

// Two pflow-agent processes, started (and stopped with SIGTERM) through a Supervisor of the test's own.
class TwoAgents : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!haveMpirun()) GTEST_SKIP() << "mpirun not installed";
    auto server = rpc::ServerRunner::start("127.0.0.1:0", {&m_manager});
    ASSERT_TRUE(server) << server.status().toString();
    m_managerServer = std::move(server.value());
    // The fake worker: rank r takes the r-th device of --devices and says where it runs.
    m_worker = testing::writeScript(m_dir / "fake-worker",
                                    "while [ $# -gt 0 ]; do case $1 in --devices) devs=$2; shift;; --job-id) job=$2; shift;; esac; shift; done\n"
                                    "r=${OMPI_COMM_WORLD_RANK:-0}\n"
                                    "dev=$(echo $devs | cut -d, -f$((r + 1)))\n"
                                    "echo \"job $job rank $r of $OMPI_COMM_WORLD_SIZE device $dev host ${TMPDIR##*/} pid $$\" >> " +
                                        (m_dir / "ranks.txt") + "\n"
                                    "case $job in long*) trap 'exit 0' TERM; while :; do sleep 0.05; done;; esac\n"
                                    "case $job in fail*) [ $r = 1 ] && { echo \"error: rank 1 cannot read the model\" >&2; exit 3; };; esac\n"
                                    "exit 0");
    startAgent("node-a", "127.0.0.1:0");
    startAgent("node-b", secondLoopback() + ":0");
    ASSERT_TRUE(m_manager.waitFor(
        [&] { return m_manager.heartbeatCount["node-a"] > 0 && m_manager.heartbeatCount["node-b"] > 0; }, 20))
        << testing::readFile(m_dir / "agent-node-a.log") << testing::readFile(m_dir / "agent-node-b.log");
  }
  void TearDown() override {
    if (!m_agents) return;
    m_agents->stopAll(15);
    std::lock_guard lock(m_mutex);
    for (const WorkerExit& x : m_agentExits) {
      EXPECT_EQ(x.exitCode, 0) << x.jobId << ": " << x.reason << "\n" << testing::readFile(m_dir / (x.jobId + ".log"));
      EXPECT_FALSE(x.killed) << x.jobId << " needed SIGKILL";
    }
  }

  void startAgent(const std::string& node, const std::string& listen) {
    LaunchPlan plan;
    plan.jobId = "agent-" + node;
    plan.logPath = m_dir / (plan.jobId + ".log");
    plan.env = {{"TMPDIR", m_dir.path()}};
    plan.argv = {PFLOW_AGENT_BIN, "--insecure", "--node", node, "--listen", listen, "--manager", m_managerServer->address(),
                 "--workdir", m_dir / ("work-" + node), "--worker", m_worker, "--force-cpu", "--cpu-slots", "1",
                 "--rsh-agent", kRsh, "--heartbeat-interval", "0.2", "--grace", "3"};
    auto pid = m_agents->start(plan);
    ASSERT_TRUE(pid) << pid.status().toString();
  }

  std::unique_ptr<av1::AgentService::Stub> stubOf(const std::string& node) {
    return av1::AgentService::NewStub(rpc::makeChannel(m_manager.latestOf(node).agent_address()));
  }

  av1::StartJobRequest spanningLease(const std::string& jobId) {
    av1::StartJobRequest req;
    av1::Lease* l = req.mutable_lease();
    l->set_job_id(jobId);
    l->set_model_uri("file:///models/" + jobId);
    l->set_manager_address(m_managerServer->address());
    for (const char* node : {"node-a", "node-b"}) {
      auto* d = l->add_devices();
      d->set_node(node);
      d->set_index(0);
      d->set_kind(cv1::DEVICE_KIND_CPU);
      (*l->mutable_node_hosts())[node] = node;  // made-up host names: pflow-rsh runs them here
    }
    return req;
  }

  std::vector<std::string> rankLines(const std::string& jobId) {
    std::vector<std::string> lines;
    std::istringstream in(testing::readFile(m_dir / "ranks.txt"));
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("job " + jobId + " ", 0) == 0) lines.push_back(line);
    }
    return lines;
  }

  TempDir m_dir;
  std::string m_worker;
  FakeNodeRegistry m_manager;
  std::unique_ptr<rpc::ServerRunner> m_managerServer;
  std::mutex m_mutex;
  std::vector<WorkerExit> m_agentExits;
  std::unique_ptr<Supervisor> m_agents = std::make_unique<Supervisor>(
      [this](const WorkerExit& x) {
        std::lock_guard lock(m_mutex);
        m_agentExits.push_back(x);
      },
      10);
};

TEST_F(TwoAgents, JobAcrossBothNodes) {
  // Both agents report their CPU slot from their own address.
  EXPECT_EQ(rpc::hostOf(m_manager.latestOf("node-a").agent_address()), "127.0.0.1");
  EXPECT_EQ(rpc::hostOf(m_manager.latestOf("node-b").agent_address()), secondLoopback());
  ASSERT_EQ(m_manager.latestOf("node-b").devices_size(), 1);
  EXPECT_EQ(m_manager.latestOf("node-b").devices(0).ref().node(), "node-b");

  // The manager sends the lease to the agent of rank 0's node.
  auto stub = stubOf("node-a");
  av1::StartJobResponse resp;
  auto ctx = rpc::contextWithDeadline(10);
  const grpc::Status s = stub->StartJob(ctx.get(), spanningLease("span-1"), &resp);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_TRUE(m_manager.waitFor([&] { return m_manager.exits.size() == 1; }, 60))
      << testing::readFile(m_dir / "work-node-a/span-1.log");
  const auto exit = m_manager.exitsCopy().at(0);
  EXPECT_EQ(exit.job_id(), "span-1");
  EXPECT_EQ(exit.node(), "node-a");
  EXPECT_EQ(exit.exit_code(), 0) << exit.reason() << "\n" << testing::readFile(m_dir / "work-node-a/span-1.log");
  EXPECT_EQ(testing::readFile(m_dir / "work-node-a/span-1.hosts"), "node-a slots=1\nnode-b slots=1\n");

  const auto lines = rankLines("span-1");
  ASSERT_EQ(lines.size(), 2u) << testing::readFile(m_dir / "ranks.txt");
  std::set<std::string> seen;
  for (const auto& l : lines) seen.insert(l.substr(0, l.find(" pid")));
  EXPECT_TRUE(seen.count("job span-1 rank 0 of 2 device node-a:cpu:0 host node-a")) << lines[0] << "\n" << lines[1];
  EXPECT_TRUE(seen.count("job span-1 rank 1 of 2 device node-b:cpu:0 host node-b")) << lines[0] << "\n" << lines[1];
}

TEST_F(TwoAgents, FailingRankIsReportedWithItsError) {
  auto stub = stubOf("node-a");
  av1::StartJobResponse resp;
  auto ctx = rpc::contextWithDeadline(10);
  const grpc::Status s = stub->StartJob(ctx.get(), spanningLease("fail-1"), &resp);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_TRUE(m_manager.waitFor([&] { return m_manager.exits.size() == 1; }, 60));
  const auto exit = m_manager.exitsCopy().at(0);
  EXPECT_EQ(exit.exit_code(), 3) << testing::readFile(m_dir / "work-node-a/fail-1.log");
  EXPECT_EQ(exit.reason(), "error: rank 1 cannot read the model") << testing::readFile(m_dir / "work-node-a/fail-1.log");
}

TEST_F(TwoAgents, StopReachesRanksOnBothNodes) {
  auto stub = stubOf("node-a");
  av1::StartJobResponse resp;
  {
    auto ctx = rpc::contextWithDeadline(10);
    const grpc::Status s = stub->StartJob(ctx.get(), spanningLease("long-1"), &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
  }
  ASSERT_TRUE(waitUntil([&] { return rankLines("long-1").size() == 2; }, 60))
      << testing::readFile(m_dir / "work-node-a/long-1.log");
  std::vector<int> pids;
  for (const auto& l : rankLines("long-1")) pids.push_back(std::atoi(l.substr(l.rfind(' ') + 1).c_str()));
  {
    av1::StopJobRequest req;
    req.set_job_id("long-1");
    av1::StopJobResponse stopped;
    auto ctx = rpc::contextWithDeadline(10);
    ASSERT_TRUE(stub->StopJob(ctx.get(), req, &stopped).ok());
  }
  ASSERT_TRUE(m_manager.waitFor([&] { return m_manager.exits.size() == 1; }, 30));
  EXPECT_EQ(m_manager.exitsCopy().at(0).reason().rfind("stopped: SIGTERM", 0), 0u) << m_manager.exitsCopy().at(0).reason();
  for (int pid : pids) EXPECT_TRUE(waitUntil([&] { return !testing::processAlive(pid); }, 10)) << "rank pid " << pid;
}

}  // namespace
}  // namespace pflow::agent
