// Unit tests of the supervisor: mpirun command lines and hostfiles, the log's last error line, and fake workers
// (/bin/sh scripts launched directly) that exit, fail, stop on SIGTERM or need SIGKILL.
#include "manager/agent/Supervisor.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>
#include <cstdlib>
#include <mutex>
#include <optional>
#include <vector>

#include "tests/agent/AgentTestUtil.h"

namespace pflow::agent {
namespace {

using testing::TempDir;
using testing::waitUntil;

Lease twoGpuLease() {
  Lease l;
  l.jobId = "job-1";
  l.modelUri = "file:///data/model-1.pb";
  l.devices = {{"node-a", DeviceKind::kGpu, 0}, {"node-a", DeviceKind::kGpu, 1}};
  l.managerAddress = "10.0.0.1:50051";
  l.backendAddress = "10.0.0.2:50071";
  return l;
}

bool contains(const std::vector<std::string>& v, const std::vector<std::string>& seq) {
  return std::search(v.begin(), v.end(), seq.begin(), seq.end()) != v.end();
}

TEST(LaunchPlan, SingleNodeLeaseHasNoHostfile) {
  LaunchConfig config;
  config.workdir = "/var/lib/pflow";
  config.workerPath = "/opt/pflow/bin/pflow-worker";
  config.passEnv = {};
  const LaunchPlan plan = planLaunch(twoGpuLease(), config, "node-a");
  const std::vector<std::string> expected{
      "mpirun", "-np", "2", "--oversubscribe", "--bind-to", "none", "--map-by", "slot",
      "-x", "CUDA_DEVICE_ORDER", "-x", "PFLOW_JOB_ID",
      "/opt/pflow/bin/pflow-worker", "--job-id", "job-1", "--model", "file:///data/model-1.pb",
      "--manager", "10.0.0.1:50051", "--backend", "10.0.0.2:50071", "--devices", "node-a:gpu:0,node-a:gpu:1"};
  EXPECT_EQ(plan.argv, expected);
  EXPECT_TRUE(plan.hostfilePath.empty());
  EXPECT_TRUE(plan.hostfileText.empty());
  EXPECT_EQ(plan.logPath, "/var/lib/pflow/job-1.log");
  EXPECT_EQ(plan.rankDevices, twoGpuLease().devices);
  const auto has = [&](const std::string& k, const std::string& v) {
    return std::find(plan.env.begin(), plan.env.end(), std::make_pair(k, v)) != plan.env.end();
  };
  EXPECT_TRUE(has("OMPI_ALLOW_RUN_AS_ROOT", "1"));
  EXPECT_TRUE(has("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"));
  EXPECT_TRUE(has("CUDA_DEVICE_ORDER", "PCI_BUS_ID"));
  EXPECT_TRUE(has("PFLOW_JOB_ID", "job-1"));
}

TEST(LaunchPlan, TwoNodeLeaseWritesHostfileAndGroupsRanksByHost) {
  Lease l = twoGpuLease();
  // Interleaved on purpose: ranks are regrouped by host so mpirun's by-slot mapping matches --devices.
  l.devices = {{"node-a", DeviceKind::kGpu, 0}, {"node-b", DeviceKind::kGpu, 3}, {"node-a", DeviceKind::kGpu, 1}};
  l.nodeHosts = {{"node-a", "gpu-a.cluster"}, {"node-b", "gpu-b.cluster"}};
  LaunchConfig config;
  config.workdir = "/w";
  config.workerPath = "pflow-worker";
  config.rshAgent = "/opt/pflow/deploy/local/pflow-rsh";
  config.passEnv = {};
  const LaunchPlan plan = planLaunch(l, config, "node-a");
  EXPECT_EQ(plan.hostfilePath, "/w/job-1.hosts");
  EXPECT_EQ(plan.hostfileText, "gpu-a.cluster slots=2\ngpu-b.cluster slots=1\n");
  const std::vector<DeviceRef> ranks{{"node-a", DeviceKind::kGpu, 0}, {"node-a", DeviceKind::kGpu, 1},
                                     {"node-b", DeviceKind::kGpu, 3}};
  EXPECT_EQ(plan.rankDevices, ranks);
  EXPECT_TRUE(contains(plan.argv, {"mpirun", "-np", "3"}));
  EXPECT_TRUE(contains(plan.argv, {"--hostfile", "/w/job-1.hosts"}));
  EXPECT_TRUE(contains(plan.argv, {"--mca", "plm_rsh_agent", "/opt/pflow/deploy/local/pflow-rsh"}));
  EXPECT_TRUE(contains(plan.argv, {"--devices", "node-a:gpu:0,node-a:gpu:1,node-b:gpu:3"}));
  EXPECT_EQ(plan.argv.back(), "node-a:gpu:0,node-a:gpu:1,node-b:gpu:3");
}

TEST(LaunchPlan, LocalNodeWithoutHostEntryUsesItsNameAndCpuSlots) {
  Lease l;
  l.jobId = "j";
  l.modelUri = "m";
  l.devices = {{"node-b", DeviceKind::kCpu, 0}, {"node-a", DeviceKind::kCpu, 0}};
  l.nodeHosts = {{"node-b", "127.0.0.2"}};
  LaunchConfig config;
  config.workdir = "/w";
  const LaunchPlan plan = planLaunch(l, config, "node-a");
  EXPECT_EQ(plan.hostfileText, "127.0.0.2 slots=1\nnode-a slots=1\n");
  EXPECT_EQ(plan.argv.back(), "node-b:cpu:0,node-a:cpu:0");
  // No --manager/--backend when the lease has none.
  EXPECT_EQ(std::find(plan.argv.begin(), plan.argv.end(), "--manager"), plan.argv.end());
  EXPECT_EQ(std::find(plan.argv.begin(), plan.argv.end(), "--backend"), plan.argv.end());
}

TEST(LaunchPlan, PassesOnlyEnvironmentThatIsSet) {
  ::setenv("PFLOW_TEST_SET", "1", 1);
  ::unsetenv("PFLOW_TEST_UNSET");
  LaunchConfig config;
  config.passEnv = {"PFLOW_TEST_SET", "PFLOW_TEST_UNSET"};
  config.extraMpirunArgs = {"--mca", "btl", "self,tcp"};
  const LaunchPlan plan = planLaunch(twoGpuLease(), config, "node-a");
  EXPECT_TRUE(contains(plan.argv, {"-x", "PFLOW_TEST_SET", "--mca", "btl", "self,tcp", "pflow-worker"}));
  EXPECT_FALSE(contains(plan.argv, {"-x", "PFLOW_TEST_UNSET"}));
}

TEST(LaunchPlan, DirectLaunchWithPrefix) {
  LaunchConfig config;
  config.mpirun = "";
  config.launcherPrefix = {"/usr/bin/env", "X=1"};
  config.workerPath = "/bin/worker";
  const LaunchPlan plan = planLaunch(twoGpuLease(), config, "node-a");
  ASSERT_GE(plan.argv.size(), 3u);
  EXPECT_EQ(plan.argv[0], "/usr/bin/env");
  EXPECT_EQ(plan.argv[1], "X=1");
  EXPECT_EQ(plan.argv[2], "/bin/worker");
  EXPECT_EQ(std::find(plan.argv.begin(), plan.argv.end(), "mpirun"), plan.argv.end());
}

TEST(LastErrorLine, PrefersErrorsSkipsRulersAndStartsAtOffset) {
  TempDir dir;
  const std::string log = dir / "x.log";
  testing::writeFile(log, "old run: error: stale\n=== header\nstep 1\nERROR: particle 17 left the domain\nstep 2\n-----\n\n");
  EXPECT_EQ(lastErrorLine(log), "ERROR: particle 17 left the domain");
  testing::writeFile(log, "step 1\nstep 2\n  -------  \n");
  EXPECT_EQ(lastErrorLine(log), "step 2");
  testing::writeFile(log, "error: old\nstep 9\n");
  EXPECT_EQ(lastErrorLine(log, 11), "step 9");
  EXPECT_EQ(lastErrorLine(dir / "missing.log"), "");
}

// What mpirun 4.1 prints when a rank fails (captured on this machine).
constexpr const char* kRuler = "--------------------------------------------------------------------------\n";

TEST(LastErrorLine, WorkerErrorBeatsMpirunNotices) {
  TempDir dir;
  const std::string log = dir / "x.log";
  testing::writeFile(log, std::string("step 1 rank 0\nerror: particle 17 left the domain\nstep 1 rank 1\n") + kRuler +
                              "Primary job  terminated normally, but 1 process returned\n"
                              "a non-zero exit code. Per user-direction, the job has been aborted.\n" +
                              kRuler + kRuler +
                              "mpirun detected that one or more processes exited with non-zero status, thus causing\n"
                              "the job to be terminated. The first process to do so was:\n\n"
                              "  Process name: [[815,1],1]\n  Exit code:    3\n" + kRuler);
  EXPECT_EQ(lastErrorLine(log), "error: particle 17 left the domain");
}

TEST(LastErrorLine, MpirunNoticeOfASignal) {
  TempDir dir;
  const std::string log = dir / "x.log";
  testing::writeFile(log, std::string(kRuler) + "Primary job  terminated normally, but 1 process returned\n"
                              "a non-zero exit code. Per user-direction, the job has been aborted.\n" + kRuler + kRuler +
                              "mpirun noticed that process rank 1 with PID 0 on node vm exited on signal 11 (Segmentation fault).\n" +
                              kRuler);
  EXPECT_EQ(lastErrorLine(log), "mpirun noticed that process rank 1 with PID 0 on node vm exited on signal 11 (Segmentation fault).");
}

// A supervisor whose exits are collected for the test.
class SupervisorTest : public ::testing::Test {
 protected:
  LaunchPlan plan(const std::string& jobId, const std::string& scriptBody) {
    const std::string script = testing::writeScript(m_dir / (jobId + ".sh"), scriptBody);
    LaunchConfig config;
    config.mpirun = "";
    config.workdir = m_dir.path();
    config.workerPath = script;
    Lease l;
    l.jobId = jobId;
    l.modelUri = "model";
    l.devices = {{"n", DeviceKind::kCpu, 0}};
    return planLaunch(l, config, "n");
  }
  bool waitExit(const std::string& jobId, double seconds = 10) {
    return waitUntil([&] { return exitOf(jobId).has_value(); }, seconds);
  }
  std::optional<WorkerExit> exitOf(const std::string& jobId) {
    std::lock_guard lock(m_mutex);
    for (const auto& x : m_exits) {
      if (x.jobId == jobId) return x;
    }
    return std::nullopt;
  }
  std::string log(const std::string& jobId) { return testing::readFile(m_dir / (jobId + ".log")); }
  bool waitLog(const std::string& jobId, const std::string& text) {
    return waitUntil([&] { return log(jobId).find(text) != std::string::npos; }, 10);
  }

  TempDir m_dir;
  std::mutex m_mutex;
  std::vector<WorkerExit> m_exits;
  Supervisor m_sup{[this](const WorkerExit& x) {
                     std::lock_guard lock(m_mutex);
                     m_exits.push_back(x);
                   },
                   0.5};
};

TEST_F(SupervisorTest, NormalExitZero) {
  auto pid = m_sup.start(plan("ok", "echo \"worker $*\"; echo \"job $PFLOW_JOB_ID order $CUDA_DEVICE_ORDER\"; exit 0"));
  ASSERT_TRUE(pid) << pid.status().toString();
  EXPECT_GT(pid.value(), 0);
  ASSERT_TRUE(waitExit("ok"));
  const WorkerExit x = *exitOf("ok");
  EXPECT_EQ(x.exitCode, 0);
  EXPECT_EQ(x.signal, 0);
  EXPECT_EQ(x.reason, "");
  EXPECT_FALSE(x.stopRequested);
  EXPECT_TRUE(waitUntil([&] { return !m_sup.isRunning("ok"); }, 5));
  const std::string text = log("ok");
  EXPECT_NE(text.find("=== pflow-agent"), std::string::npos);
  EXPECT_NE(text.find("worker --job-id ok --model model --devices n:cpu:0"), std::string::npos) << text;
  EXPECT_NE(text.find("job ok order PCI_BUS_ID"), std::string::npos) << text;
}

TEST_F(SupervisorTest, NonZeroExitGivesLastErrorLineAsReason) {
  ASSERT_TRUE(m_sup.start(plan("bad", "echo step 1; echo 'error: time step too large (dt 1e-3 > 2e-5)' >&2; echo bye; exit 3")));
  ASSERT_TRUE(waitExit("bad"));
  const WorkerExit x = *exitOf("bad");
  EXPECT_EQ(x.exitCode, 3);
  EXPECT_EQ(x.reason, "error: time step too large (dt 1e-3 > 2e-5)");
}

TEST_F(SupervisorTest, RestartedJobReasonIgnoresEarlierRuns) {
  ASSERT_TRUE(m_sup.start(plan("again", "echo 'error: first run'; exit 1")));
  ASSERT_TRUE(waitExit("again"));
  ASSERT_TRUE(waitUntil([&] { return !m_sup.isRunning("again"); }, 5));
  {
    std::lock_guard lock(m_mutex);
    m_exits.clear();
  }
  ASSERT_TRUE(m_sup.start(plan("again", "echo 'second run'; exit 2")));
  ASSERT_TRUE(waitExit("again"));
  EXPECT_EQ(exitOf("again")->reason, "second run");
  EXPECT_NE(log("again").find("error: first run"), std::string::npos);  // the log is appended
}

TEST_F(SupervisorTest, StopSendsSigterm) {
  ASSERT_TRUE(m_sup.start(plan("term", "trap 'echo got TERM; exit 7' TERM; echo ready; while :; do sleep 0.05; done")));
  ASSERT_TRUE(waitLog("term", "ready"));
  ASSERT_TRUE(m_sup.stop("term").isOk());
  EXPECT_TRUE(m_sup.stop("term").isOk());  // again: harmless
  ASSERT_TRUE(waitExit("term"));
  const WorkerExit x = *exitOf("term");
  EXPECT_EQ(x.exitCode, 7);
  EXPECT_TRUE(x.stopRequested);
  EXPECT_FALSE(x.killed);
  EXPECT_EQ(x.reason, "stopped: SIGTERM");
  EXPECT_NE(log("term").find("got TERM"), std::string::npos);
}

TEST_F(SupervisorTest, StopAgainAfterTheExitWasReapedIsHarmless) {
  // The race one full-suite run hit: the worker exits on SIGTERM at once, the reaper hands the exit over and drops
  // the job, and only then comes the second stop. It must still be OK; an id never started stays NOT_FOUND.
  ASSERT_TRUE(m_sup.start(plan("quick", "trap 'exit 0' TERM; echo ready; while :; do sleep 0.05; done")));
  ASSERT_TRUE(waitLog("quick", "ready"));
  ASSERT_TRUE(m_sup.stop("quick").isOk());
  ASSERT_TRUE(waitExit("quick"));
  ASSERT_TRUE(waitUntil([&] { return !m_sup.isRunning("quick"); }, 5));
  EXPECT_TRUE(m_sup.stop("quick").isOk());
  EXPECT_EQ(m_sup.stop("never").code(), StatusCode::kNotFound);
  // Started again, it is a new run: once it ends on its own, a stop is NOT_FOUND again.
  ASSERT_TRUE(m_sup.start(plan("quick", "exit 0")));
  ASSERT_TRUE(waitUntil([&] { return !m_sup.isRunning("quick"); }, 5));
  EXPECT_EQ(m_sup.stop("quick").code(), StatusCode::kNotFound);
}

TEST_F(SupervisorTest, WorkerIgnoringSigtermIsKilledAfterGrace) {
  // The worker and a helper in a process group of its own (as mpirun's ranks are) both ignore SIGTERM.
  const std::string pidFile = m_dir / "helper.pid";
  ASSERT_TRUE(m_sup.start(plan("stubborn", "trap '' TERM; set -m; sleep 100 & echo $! > " + pidFile +
                                               "; echo ready; while :; do sleep 0.05; done")));
  ASSERT_TRUE(waitLog("stubborn", "ready"));
  const int helper = std::atoi(testing::readFile(pidFile).c_str());
  ASSERT_GT(helper, 0);
  ASSERT_TRUE(testing::processAlive(helper));
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(m_sup.stop("stubborn").isOk());
  ASSERT_TRUE(waitExit("stubborn"));
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const WorkerExit x = *exitOf("stubborn");
  EXPECT_GE(took, 0.45);
  EXPECT_EQ(x.signal, 9);
  EXPECT_EQ(x.exitCode, 137);
  EXPECT_TRUE(x.killed);
  EXPECT_NE(x.reason.find("SIGKILL after 0.5 s grace"), std::string::npos) << x.reason;
  EXPECT_TRUE(waitUntil([&] { return !testing::processAlive(helper); }, 5)) << "helper " << helper << " survived";
}

TEST_F(SupervisorTest, LeftoversOfAFinishedWorkerAreKilled) {
  const std::string pidFile = m_dir / "left.pid";
  ASSERT_TRUE(m_sup.start(plan("leaves", "set -m; sleep 100 & echo $! > " + pidFile + "; exit 0")));
  ASSERT_TRUE(waitExit("leaves"));
  const int helper = std::atoi(testing::readFile(pidFile).c_str());
  ASSERT_GT(helper, 0);
  EXPECT_TRUE(waitUntil([&] { return !testing::processAlive(helper); }, 5));
}

TEST_F(SupervisorTest, ExternalSignalIsReported) {
  ASSERT_TRUE(m_sup.start(plan("crash", "echo 'loading'; echo ready; kill -SEGV $$; sleep 5")));
  ASSERT_TRUE(waitExit("crash"));
  const WorkerExit x = *exitOf("crash");
  EXPECT_EQ(x.signal, 11);
  EXPECT_EQ(x.exitCode, 139);
  EXPECT_FALSE(x.stopRequested);
  EXPECT_NE(x.reason.find("killed by signal 11"), std::string::npos) << x.reason;
  EXPECT_NE(x.reason.find("last log line: ready"), std::string::npos) << x.reason;
}

TEST_F(SupervisorTest, DuplicateMissingProgramAndUnknownJob) {
  ASSERT_TRUE(m_sup.start(plan("dup", "sleep 0.5")));
  auto again = m_sup.start(plan("dup", "sleep 0.5"));
  EXPECT_EQ(again.status().code(), StatusCode::kAlreadyExists);

  LaunchPlan missing = plan("missing", "true");
  missing.argv[0] = m_dir / "no-such-program";
  auto r = m_sup.start(missing);
  EXPECT_EQ(r.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(r.status().message().find("No such file"), std::string::npos) << r.status().message();
  EXPECT_FALSE(m_sup.isRunning("missing"));

  EXPECT_EQ(m_sup.stop("nope").code(), StatusCode::kNotFound);
  EXPECT_TRUE(m_sup.stopAll(5));
  EXPECT_TRUE(m_sup.running().empty());
}

TEST_F(SupervisorTest, WritesTheHostfile) {
  LaunchPlan p = plan("hosts", "cat \"$0.hosts\" 2>/dev/null; exit 0");
  p.hostfilePath = m_dir / "hosts.hosts";
  p.hostfileText = "a slots=1\nb slots=2\n";
  ASSERT_TRUE(m_sup.start(p));
  ASSERT_TRUE(waitExit("hosts"));
  EXPECT_EQ(testing::readFile(p.hostfilePath), "a slots=1\nb slots=2\n");
}

// An agent started again finds the pid files its earlier run left: a worker still running (its command line names
// the job) is stopped (SIGTERM to its session) and reported; a pid that is gone, or that another program now holds,
// is reported as ended while the agent was down, and that program is left alone.
TEST(StopOrphans, StopsWorkersThatOutlivedTheirAgentAndReportsEveryPidFile) {
  TempDir dir;
  const pid_t orphan = ::fork();
  ASSERT_GE(orphan, 0);
  if (orphan == 0) {
    ::setsid();
    ::execl("/bin/sh", "sh", "-c", "sleep 30", "pflow-worker", "--job-id", "job-orphan", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  const pid_t other = ::fork();  // a program that now holds a pid a file names: alive, but not that job's worker
  ASSERT_GE(other, 0);
  if (other == 0) {
    ::setsid();
    ::execl("/bin/sh", "sh", "-c", "sleep 30", "pflow-worker", "--job-id", "job-elsewhere", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // exec'd
  std::ofstream(pidFilePath(dir.path(), "job-orphan")) << orphan << "\n";
  std::ofstream(pidFilePath(dir.path(), "job-gone")) << 999999 << "\n";
  std::ofstream(pidFilePath(dir.path(), "job-other")) << other << "\n";
  const auto exits = stopOrphans(dir.path(), 5);
  ASSERT_EQ(exits.size(), 3u);
  for (const WorkerExit& x : exits) {
    EXPECT_EQ(x.exitCode, 137) << x.jobId;
    if (x.jobId == "job-orphan") {
      EXPECT_NE(x.reason.find("outlived the agent"), std::string::npos) << x.reason;
      EXPECT_FALSE(x.killed);  // SIGTERM was enough
    } else {
      EXPECT_NE(x.reason.find("ended while its agent was down"), std::string::npos) << x.jobId << ": " << x.reason;
    }
  }
  int status = 0;
  ASSERT_EQ(::waitpid(orphan, &status, 0), orphan);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM);
  EXPECT_EQ(::waitpid(other, &status, WNOHANG), 0) << "the other program was stopped";  // still running
  ::kill(-other, SIGKILL);
  ::waitpid(other, &status, 0);
  EXPECT_FALSE(std::filesystem::exists(pidFilePath(dir.path(), "job-orphan")));
  EXPECT_TRUE(stopOrphans(dir.path(), 5).empty());
}

// The supervisor writes a worker's pid file while it runs and removes it once the worker is reaped.
TEST_F(SupervisorTest, PidFileWhileTheWorkerRuns) {
  ASSERT_TRUE(m_sup.start(plan("pidfile", "sleep 0.5; exit 0")));
  std::ifstream in(pidFilePath(m_dir.path(), "pidfile"));
  int pid = 0;
  in >> pid;
  EXPECT_GT(pid, 1);
  ASSERT_TRUE(waitExit("pidfile"));
  EXPECT_FALSE(std::filesystem::exists(pidFilePath(m_dir.path(), "pidfile")));
}

}  // namespace
}  // namespace pflow::agent
