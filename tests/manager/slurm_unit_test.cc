// Placement through Slurm without Slurm: the parsers against output captured from Debian's slurm-wlm 22.05, the
// pure rules (node views, the request, the batch script, what each Slurm state means), and the Manager driving a
// fake Slurm through a job's life (submit, pending, running, the end, cancel, requeue, a restart).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>

#include "common/LogTail.h"
#include "compute/worker/WorkerOptions.h"
#include "manager/JobStore.h"
#include "manager/Manager.h"
#include "manager/slurm/SlurmCommands.h"
#include "manager/slurm/SlurmParse.h"
#include "manager/slurm/SlurmPlacement.h"
#include "tests/manager/Fakes.h"

namespace pflow::manager {
namespace {

using namespace slurm;
using testing::FakeAgentClient;
using testing::FakeFrontendClient;
using testing::submitRequest;

// Lines as `scontrol -o show node` and `scontrol -o -d show job` print them (slurm-wlm 22.05.8, trimmed).
const char* kNodeLine =
    "NodeName=gpu07 Arch=x86_64 CoresPerSocket=16 CPUAlloc=8 CPUEfctv=32 CPUTot=32 CPULoad=3.25 AvailableFeatures=(null) "
    "ActiveFeatures=(null) Gres=gpu:h100:4(S:0-1) NodeAddr=10.0.0.7 NodeHostName=gpu07 Version=22.05.8 OS=Linux 6.1.0-18-amd64 #1 "
    "SMP PREEMPT_DYNAMIC Debian 6.1.76-1 (2024-02-01) RealMemory=515000 AllocMem=0 FreeMem=500000 Sockets=2 Boards=1 "
    "State=MIXED ThreadsPerCore=1 TmpDisk=0 Weight=1 Owner=N/A MCS_label=N/A Partitions=gpu,all BootTime=2026-11-25T17:26:16 "
    "CfgTRES=cpu=32,mem=515000M,billing=32,gres/gpu=4 AllocTRES=cpu=8,gres/gpu=2 CapWatts=n/a";
const char* kDrainedLine =
    "NodeName=cpu01 Arch=x86_64 CPUAlloc=0 CPUTot=4 CPULoad=0.00 Gres=(null) NodeAddr=127.0.0.1 RealMemory=4096 "
    "State=IDLE+DRAIN ThreadsPerCore=1 Partitions=pflow Reason=disk replaced [root@2026-11-26T13:00:00] AllocTRES=";
const char* kJobLine =
    "JobId=42 JobName=pflow-job-000007 UserId=root(0) GroupId=root(0) Priority=4294901759 Nice=0 Account=(null) QOS=(null) "
    "JobState=RUNNING Reason=None Dependency=(null) Requeue=0 Restarts=0 BatchFlag=1 Reboot=0 ExitCode=0:0 "
    "DerivedExitCode=0:0 RunTime=00:00:03 TimeLimit=1-00:00:00 NodeList=gpu[07-08] BatchHost=gpu07 NumNodes=2 NumCPUs=4 "
    "NumTasks=4 CPUs/Task=1 TRES=cpu=4,node=2,billing=4,gres/gpu=4 JOB_GRES=gpu:4 Nodes=gpu[07-08] CPU_IDs=0-1 Mem=0 "
    "GRES=gpu(IDX:2-3) Comment=pflow job-000007 attempt 2 StdErr=/shared/pflow/job-000007-2.log StdOut=/shared/pflow/job-000007-2.log";

TEST(SlurmParse, RecordsKeepValuesWithSpaces) {
  const Record r = parseRecord(kNodeLine);
  EXPECT_EQ(field(r, "NodeName"), "gpu07");
  EXPECT_EQ(field(r, "OS"), "Linux 6.1.0-18-amd64 #1 SMP PREEMPT_DYNAMIC Debian 6.1.76-1 (2024-02-01)");
  EXPECT_EQ(field(r, "RealMemory"), "515000");
  EXPECT_EQ(field(r, "missing"), "");
  EXPECT_EQ(parseRecords(std::string(kNodeLine) + "\n\n" + kDrainedLine + "\n").size(), 2u);
}

TEST(SlurmParse, HostAndIdLists) {
  EXPECT_EQ(expandHostList("gpu[07-09,11],login").value(), (std::vector<std::string>{"gpu07", "gpu08", "gpu09", "gpu11", "login"}));
  EXPECT_EQ(expandHostList("n[8-10]").value(), (std::vector<std::string>{"n8", "n9", "n10"}));
  EXPECT_EQ(expandHostList("rack[1-2]-n[01-02],x").value(),
            (std::vector<std::string>{"rack1-n01", "rack1-n02", "rack2-n01", "rack2-n02", "x"}));
  EXPECT_TRUE(expandHostList("(null)").value().empty());
  EXPECT_FALSE(expandHostList("gpu[07-09"));
  EXPECT_FALSE(expandHostList("gpu[9-7]"));
  EXPECT_EQ(expandIdList("0-3,8").value(), (std::vector<int>{0, 1, 2, 3, 8}));
  EXPECT_FALSE(expandIdList("0-x"));
}

TEST(SlurmParse, GpuCounts) {
  EXPECT_EQ(gpuCount("gpu:4"), 4);
  EXPECT_EQ(gpuCount("gpu:h100:4(S:0-1)"), 4);
  EXPECT_EQ(gpuCount("gpu:a100:2,gpu:h100:2"), 4);
  EXPECT_EQ(gpuCount("cpu=8,gres/gpu=2,gres/gpu:h100=2"), 2);
  EXPECT_EQ(gpuCount("cpu=8"), 0);
  EXPECT_EQ(gpuCount("gpu"), 1);
  EXPECT_EQ(gpuCount("gpu:h100"), 1);
}

TEST(SlurmParse, NodesAndJobs) {
  const NodeInfo n = nodeFromRecord(parseRecord(kNodeLine));
  EXPECT_EQ(n.name, "gpu07");
  EXPECT_EQ(n.gpus, 4);
  EXPECT_EQ(n.gpusAllocated, 2);
  EXPECT_EQ(n.gpuType, "h100");
  EXPECT_EQ(n.cpus, 32);
  EXPECT_DOUBLE_EQ(n.cpuLoad, 3.25);
  EXPECT_EQ(n.memoryBytes, 515000ull << 20);
  EXPECT_EQ(n.partitions, (std::vector<std::string>{"gpu", "all"}));
  const NodeInfo d = nodeFromRecord(parseRecord(kDrainedLine));
  EXPECT_EQ(d.state, "IDLE+DRAIN");
  EXPECT_EQ(d.reason, "disk replaced [root@2026-11-26T13:00:00]");

  const JobInfo j = jobFromRecord(parseRecord(kJobLine));
  EXPECT_EQ(j.id, "42");
  EXPECT_EQ(j.state, "RUNNING");
  EXPECT_EQ(j.comment, "pflow job-000007 attempt 2");
  EXPECT_EQ(j.stdOut, "/shared/pflow/job-000007-2.log");
  ASSERT_EQ(j.devices.size(), 4u);  // the GPUs of both nodes, not their CPUs
  EXPECT_EQ(j.devices[0], (DeviceKey{"gpu07", 2, DeviceKind::kGpu}));
  EXPECT_EQ(j.devices[3], (DeviceKey{"gpu08", 3, DeviceKind::kGpu}));
  const JobInfo mixed = jobFromRecord(parseRecord("JobId=44 JobState=RUNNING Nodes=g1 CPU_IDs=0-3 GRES=gpu:a100:1(IDX:0),gpu:h100:2(IDX:2-3)"));
  EXPECT_EQ(mixed.devices, (std::vector<DeviceKey>{{"g1", 0, DeviceKind::kGpu}, {"g1", 2, DeviceKind::kGpu}, {"g1", 3, DeviceKind::kGpu}}));
  const JobInfo failed = jobFromRecord(parseRecord("JobId=43 JobState=FAILED Reason=NonZeroExitCode ExitCode=0:9 Nodes=cpu01 CPU_IDs=0,2 GRES="));
  EXPECT_EQ(failed.exitSignal, 9);
  EXPECT_EQ(failed.devices, (std::vector<DeviceKey>{{"cpu01", 0, DeviceKind::kCpu}, {"cpu01", 2, DeviceKind::kCpu}}));
}

TEST(SlurmPlacement, NodeViewsShowGpusOrSlotsAndWhoHoldsThem) {
  SlurmSettings settings;
  settings.gpuMemoryBytes = 80ull << 30;
  JobInfo running = jobFromRecord(parseRecord(kJobLine));
  const auto views = nodeViews({nodeFromRecord(parseRecord(kNodeLine)), nodeFromRecord(parseRecord(kDrainedLine))}, {running},
                               {{"42", "job-000007"}}, settings);
  ASSERT_EQ(views.size(), 2u);
  const NodeView& g = views[0];
  EXPECT_EQ(g.slurmState, "MIXED");
  EXPECT_DOUBLE_EQ(g.cpuLoad, 3.25);
  ASSERT_EQ(g.devices.size(), 4u);
  EXPECT_EQ(g.devices[0].state, DeviceState::kFree);
  EXPECT_EQ(g.devices[2].state, DeviceState::kBusy);
  EXPECT_EQ(g.devices[2].jobId, "job-000007");
  EXPECT_EQ(g.devices[2].info.memoryTotalBytes, 80ull << 30);
  EXPECT_EQ(g.devices[0].info.name, "GPU h100 (Slurm GRES)");
  const NodeView& c = views[1];  // drained: lost, its CPUs as slots
  EXPECT_TRUE(c.lost);
  EXPECT_EQ(c.slurmReason, "disk replaced [root@2026-11-26T13:00:00]");
  ASSERT_EQ(c.devices.size(), 4u);
  EXPECT_EQ(c.devices[0].state, DeviceState::kLost);
  EXPECT_EQ(c.devices[0].info.key.kind, DeviceKind::kCpu);
  settings.partition = "gpu";
  EXPECT_EQ(nodeViews({nodeFromRecord(parseRecord(kNodeLine)), nodeFromRecord(parseRecord(kDrainedLine))}, {}, {}, settings).size(), 1u);
}

TEST(SlurmPlacement, RequestFollowsTheDevicesThatExist) {
  SlurmSettings settings;
  settings.gpuMemoryBytes = 80ull << 30;
  settings.workdir = "/shared/pflow";
  settings.partition = "gpu";
  settings.timeLimit = "2:00:00";
  PlacementThresholds th;
  th.particlesPerGpu = 1000000;
  const auto views = nodeViews({nodeFromRecord(parseRecord(kNodeLine))}, {jobFromRecord(parseRecord(kJobLine))}, {}, settings);
  Job job;
  job.id = "job-000009";
  job.particles = 3500000;  // deserves 3 GPUs; two are busy, Slurm will wait for them
  const Request r = requestFor(job, 1, views, th, settings);
  ASSERT_TRUE(r.fits) << r.reason;
  EXPECT_EQ(r.kind, DeviceKind::kGpu);
  EXPECT_EQ(r.submission.tasks, 3);
  EXPECT_EQ(r.submission.gpusPerTask, 1);
  EXPECT_EQ(r.submission.scriptPath, "/shared/pflow/job-000009-1.sbatch");
  EXPECT_EQ(r.submission.comment, "pflow job-000009 attempt 1");
  const auto args = SlurmCommands::sbatchArgs(r.submission);
  for (const char* want : {"--ntasks=3", "--gpus-per-task=1", "--partition=gpu", "--time=2:00:00", "--no-requeue", "--parsable"})
    EXPECT_NE(std::find(args.begin(), args.end(), want), args.end()) << want;
  EXPECT_EQ(args.back(), "/shared/pflow/job-000009-1.sbatch");
  job.slurm = {"all", "proj42", "3-00:00:00"};  // the scene's slurm: section wins over the manager's defaults
  const Request own = requestFor(job, 2, views, th, settings);
  ASSERT_TRUE(own.fits) << own.reason;
  EXPECT_EQ(own.submission.partition, "all");
  EXPECT_EQ(own.submission.account, "proj42");
  EXPECT_EQ(own.submission.timeLimit, "3-00:00:00");
  EXPECT_EQ(own.submission.logPath, "/shared/pflow/job-000009-2.log");
  job.slurm.partition = "debug";  // no node this manager shows is in it
  const Request nowhere = requestFor(job, 1, views, th, settings);
  EXPECT_FALSE(nowhere.fits);
  EXPECT_NE(nowhere.reason.find("partition 'debug' has no nodes"), std::string::npos) << nowhere.reason;
  job.slurm = {};
  job.memoryBytes = 5 * 80e9;  // needs 5 GPUs of 80 GiB at 90 %: 4 exist
  const Request never = requestFor(job, 1, views, th, settings);
  EXPECT_FALSE(never.fits);
  EXPECT_NE(never.reason.find("needs at least 6 GPUs"), std::string::npos) << never.reason;
}

TEST(SlurmPlacement, BatchScriptStartsTheWorkerWithSrun) {
  SlurmSettings settings;
  settings.workerPath = "/opt/pflow/bin/pflow-worker";
  settings.transportArgs = {"--tls-dir", "/etc/pflow/tls"};
  Job job;
  job.id = "job-000003";
  job.modelUri = "/shared/models/it's";
  const std::string first = batchScript(job, 1, DeviceKind::kGpu, "mgr:50051", "backend:50053", settings);
  EXPECT_NE(first.find("exec srun --mpi='pmix' --kill-on-bad-exit=1 '/opt/pflow/bin/pflow-worker' '--job-id' 'job-000003'"), std::string::npos) << first;
  EXPECT_NE(first.find("'--model' '/shared/models/it'\\''s'"), std::string::npos) << first;  // quoted for bash
  EXPECT_NE(first.find("'--devices' 'slurm:gpu'"), std::string::npos);
  EXPECT_EQ(first.find("--resume"), std::string::npos);
  const std::string second = batchScript(job, 2, DeviceKind::kCpu, "mgr:50051", "backend:50053", settings);
  EXPECT_NE(second.find("'--devices' 'slurm:cpu'"), std::string::npos);
  EXPECT_NE(second.find("'--attempt' '2' '--resume'"), std::string::npos) << second;
  std::string id;
  int attempt = 0;
  ASSERT_TRUE(parseComment(commentFor("job-000003", 2), id, attempt));
  EXPECT_EQ(id, "job-000003");
  EXPECT_EQ(attempt, 2);
  EXPECT_FALSE(parseComment("someone else's job", id, attempt));
}

TEST(SlurmPlacement, WhatEachSlurmStateMeans) {
  using K = Outcome::Kind;
  auto of = [](const std::string& state, int code = 0, int signal = 0, const std::string& reason = "None") {
    JobInfo j;
    j.state = state;
    j.exitCode = code;
    j.exitSignal = signal;
    j.reason = reason;
    j.timeLimit = "01:00:00";
    return outcomeOf(j);
  };
  EXPECT_EQ(of("PENDING", 0, 0, "Resources").kind, K::kPending);
  EXPECT_EQ(of("PENDING", 0, 0, "Resources").reason, "Resources");
  EXPECT_EQ(of("RUNNING").kind, K::kRunning);
  EXPECT_EQ(of("COMPLETING").kind, K::kRunning);
  EXPECT_EQ(of("COMPLETED").kind, K::kSucceeded);
  EXPECT_EQ(of("CANCELLED").kind, K::kCancelled);
  EXPECT_EQ(of("NODE_FAIL").kind, K::kRequeue);
  EXPECT_EQ(of("PREEMPTED").kind, K::kRequeue);
  EXPECT_EQ(of("TIMEOUT").kind, K::kFailed);
  EXPECT_NE(of("TIMEOUT").reason.find("time limit of 01:00:00"), std::string::npos);
  EXPECT_EQ(of("OUT_OF_MEMORY").kind, K::kFailed);
  EXPECT_EQ(of("FAILED", 3).kind, K::kFailed);      // the simulation's own error would repeat
  EXPECT_EQ(of("FAILED", 1).kind, K::kFailed);
  EXPECT_EQ(of("FAILED", 137).kind, K::kRequeue);   // srun: a task killed by SIGKILL
  EXPECT_EQ(of("FAILED", 143).kind, K::kRequeue);   // SIGTERM
  EXPECT_EQ(of("FAILED", 0, 9).kind, K::kRequeue);  // the batch script itself killed
  EXPECT_EQ(*of("FAILED", 0, 9).exitCode, 137);
  EXPECT_EQ(of("FAILED", 2).kind, K::kRequeue);     // cut off from a service or its disk
}

TEST(SlurmPlacement, LogTailPrefersTheWorkersWordsToSrunsSummary) {
  const auto dir = std::filesystem::temp_directory_path() / "pflow-slurm-logtail";
  std::filesystem::create_directories(dir);
  const auto log = (dir / "a.log").string();
  std::ofstream(log) << "srun: cluster configuration lacks support for cpu binding\n"
                        "slurmstepd-n1: error: execve(): /opt/pflow-worker: No such file or directory\n"
                        "srun: error: n1: tasks 0-1: Exited with exit code 2\n"
                        "srun: launch/slurm: _step_signal: Terminating StepId=1.0\n";
  EXPECT_EQ(lastErrorLine(log), "slurmstepd-n1: error: execve(): /opt/pflow-worker: No such file or directory");
  std::ofstream(log) << "[worker.0] [error] particle 17 left the domain at step 20\n"
                        "particle 17 left the domain at step 20\n"
                        "srun: error: n1: task 0: Exited with exit code 3\n";
  EXPECT_EQ(lastErrorLine(log), "[worker.0] [error] particle 17 left the domain at step 20");
  std::ofstream(log) << "srun: error: n1: task 1: Killed\nsrun: Force Terminated StepId=4.0\n";
  EXPECT_EQ(lastErrorLine(log), "srun: error: n1: task 1: Killed");
  std::filesystem::remove_all(dir);
}

// The worker's device under srun (pflow-worker --devices slurm:gpu|slurm:cpu).
std::map<std::string, std::string> g_env;
const char* fakeEnv(const char* name) {
  const auto it = g_env.find(name);
  return it == g_env.end() ? nullptr : it->second.c_str();
}

TEST(SlurmWorker, DeviceFromSrunsEnvironment) {
  g_env = {{"SLURMD_NODENAME", "gpu07"}, {"SLURM_LOCALID", "3"}, {"CUDA_VISIBLE_DEVICES", "2"}};
  auto gpu = worker::slurmDevice("gpu", fakeEnv);
  ASSERT_TRUE(gpu) << gpu.status().toString();
  EXPECT_EQ(gpu.value().node, "gpu07");
  EXPECT_EQ(gpu.value().index, 0);  // the one GPU Slurm made visible to this task
  g_env["CUDA_VISIBLE_DEVICES"] = "0,1,2,3";
  EXPECT_EQ(worker::slurmDevice("gpu", fakeEnv).value().index, 3);  // all of the node's: its local id picks
  EXPECT_EQ(worker::slurmDevice("cpu", fakeEnv).value().index, 3);
  EXPECT_FALSE(worker::slurmDevice("tpu", fakeEnv));
  g_env = {{"SLURM_LOCALID", "0"}};
  const auto outside = worker::slurmDevice("cpu", fakeEnv);
  ASSERT_FALSE(outside);
  EXPECT_NE(outside.status().message().find("start the worker with srun"), std::string::npos);
}

// ---- the Manager over a fake Slurm ------------------------------------------------------------------------------

class FakeSlurm final : public SlurmClient {
 public:
  Result<std::string> submit(const Submission& s) override {
    std::lock_guard lock(mu);
    if (submitError) return *submitError;
    const std::string id = std::to_string(next++);
    submissions.push_back(s);
    JobInfo j;
    j.id = id;
    j.state = "PENDING";
    j.reason = "Priority";
    j.comment = s.comment;
    j.name = s.jobName;
    j.stdOut = s.logPath;
    jobsById[id] = j;
    return id;
  }
  Result<std::map<std::string, JobInfo>> jobs(const std::vector<std::string>&) override {
    std::lock_guard lock(mu);
    return jobsById;
  }
  Status cancel(const std::string& id) override {
    std::lock_guard lock(mu);
    cancels.push_back(id);
    if (auto it = jobsById.find(id); it != jobsById.end()) it->second.state = "CANCELLED";
    return Status::ok();
  }
  Result<std::vector<NodeInfo>> nodes() override {
    std::lock_guard lock(mu);
    return nodeList;
  }
  void set(const std::string& id, const std::string& state, int exitCode = 0, const std::string& reason = "None") {
    std::lock_guard lock(mu);
    JobInfo& j = jobsById.at(id);
    j.state = state;
    j.exitCode = exitCode;
    j.reason = reason;
    if (state != "PENDING") j.devices = {{"n1", 0, DeviceKind::kCpu}, {"n1", 1, DeviceKind::kCpu}};
  }

  std::mutex mu;
  int next = 100;
  std::map<std::string, JobInfo> jobsById;
  std::vector<Submission> submissions;
  std::vector<std::string> cancels;
  std::vector<NodeInfo> nodeList;
  std::optional<Status> submitError;
};

class ManagerSlurmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() / ("pflow-slurm-unit-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    options.managerAddress = "mgr:50051";
    options.backendAddress = "backend:50053";
    options.thresholds.particlesPerCpuSlot = 1000;
    SlurmSettings s;
    s.workdir = dir.string();
    s.pollSeconds = 1;
    options.slurm = s;
    NodeInfo n;
    n.name = "n1";
    n.state = "IDLE";
    n.cpus = 4;
    n.memoryBytes = 4096ull << 20;
    slurm.nodeList = {n};
    store = JobStore::open(":memory:").value();
    makeManager();
  }
  void TearDown() override { std::filesystem::remove_all(dir); }
  void makeManager() {
    auto m = Manager::create(options, clock, *store, agents, frontend, &slurm);
    ASSERT_TRUE(m) << m.status().toString();
    manager = std::move(m.value());
  }
  void poll() {
    clock.advance(1.5);
    manager->tick();
  }
  Job job(const std::string& id) { return manager->get(id).value(); }

  std::filesystem::path dir;
  ManagerOptions options;
  FakeClock clock;
  FakeAgentClient agents;
  FakeFrontendClient frontend;
  FakeSlurm slurm;
  std::unique_ptr<JobStore> store;
  std::unique_ptr<Manager> manager;
};

TEST_F(ManagerSlurmTest, AJobsLifeThroughSlurm) {
  poll();  // the nodes are read
  ASSERT_EQ(manager->nodes().size(), 1u);
  EXPECT_EQ(manager->nodes()[0].devices.size(), 4u);
  const std::string id = manager->submit(submitRequest(2000, true)).value().id;  // 2 slots
  ASSERT_EQ(slurm.submissions.size(), 1u);
  EXPECT_EQ(slurm.submissions[0].tasks, 2);
  EXPECT_EQ(slurm.submissions[0].gpusPerTask, 0);
  const std::string script = slurm.submissions[0].scriptPath;
  std::ifstream in(script);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("'--devices' 'slurm:cpu'"), std::string::npos) << text;
  EXPECT_NE(text.find("'--manager' 'mgr:50051' '--backend' 'backend:50053'"), std::string::npos) << text;
  Job j = job(id);
  EXPECT_EQ(j.state, JobState::kQueued);
  EXPECT_EQ(j.slurmJobId, "100");
  EXPECT_EQ(j.reason, "submitted to Slurm as job 100");

  slurm.set("100", "PENDING", 0, "Resources");
  poll();
  EXPECT_EQ(job(id).reason, "waiting in Slurm as job 100: Resources");
  slurm.set("100", "RUNNING");
  poll();
  j = job(id);
  EXPECT_EQ(j.state, JobState::kStarting);
  EXPECT_EQ(j.attempts, 1);
  EXPECT_EQ(j.devices.size(), 2u);
  EXPECT_TRUE(manager->checkJobOnNode(id, "n1"));
  EXPECT_FALSE(manager->checkJobOnNode(id, "n2"));
  Progress p;
  p.step = 10;
  p.totalSteps = 1000;
  ASSERT_TRUE(manager->reportProgress(id, p, "", 1));
  EXPECT_EQ(job(id).state, JobState::kRunning);
  EXPECT_EQ(manager->nodes()[0].devices[0].jobId, id);
  p.step = 1000;  // the worker's final report
  p.time = p.duration = 1.0;
  ASSERT_TRUE(manager->reportProgress(id, p, "finished", 1));
  slurm.set("100", "COMPLETED");
  poll();
  j = job(id);
  EXPECT_EQ(j.state, JobState::kSucceeded);
  EXPECT_EQ(j.exitCode, 0);
  EXPECT_TRUE(agents.startsCopy().empty());  // no agent was asked anything
}

TEST_F(ManagerSlurmTest, CancelPendingAndRunning) {
  poll();
  const std::string a = manager->submit(submitRequest(4000, true)).value().id;
  const std::string b = manager->submit(submitRequest(4000, true)).value().id;
  ASSERT_EQ(slurm.submissions.size(), 2u);  // Slurm queues both: pflow does not hold the second back
  EXPECT_EQ(manager->cancel(b).value().state, JobState::kCancelled);
  EXPECT_EQ(slurm.cancels, std::vector<std::string>{"101"});
  slurm.set("100", "RUNNING");
  poll();
  EXPECT_EQ(manager->cancel(a).value().state, JobState::kCancelling);
  EXPECT_EQ(slurm.cancels.back(), "100");  // scancel set it CANCELLED
  poll();
  EXPECT_EQ(job(a).state, JobState::kCancelled);
}

TEST_F(ManagerSlurmTest, FailuresFailOrRequeueWithTheReason) {
  poll();
  const std::string id = manager->submit(submitRequest(1000, true)).value().id;
  slurm.set("100", "RUNNING");
  poll();
  std::ofstream(dir / (id + "-1.log")) << "[worker.0] [error] cannot reach the back-end at backend:50053\n"
                                          "srun: error: n1: task 0: Exited with exit code 2\n";
  slurm.set("100", "FAILED", 2, "NonZeroExitCode");
  poll();  // requeued, and submitted again at once as attempt 2 with --resume
  Job j = job(id);
  EXPECT_EQ(j.state, JobState::kRequeued);
  EXPECT_NE(j.reason.find("exit code 2"), std::string::npos) << j.reason;
  EXPECT_NE(j.reason.find("cannot reach the back-end"), std::string::npos) << j.reason;
  EXPECT_NE(j.reason.find("attempt 1 of 3; requeued"), std::string::npos) << j.reason;
  EXPECT_NE(j.reason.find("; now submitted to Slurm as job 101"), std::string::npos) << j.reason;
  ASSERT_EQ(slurm.submissions.size(), 2u);
  EXPECT_EQ(slurm.submissions[1].comment, "pflow " + id + " attempt 2");
  std::ifstream in(slurm.submissions[1].scriptPath);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("'--attempt' '2' '--resume'"), std::string::npos) << text;
  slurm.set("101", "NODE_FAIL");
  poll();
  EXPECT_EQ(job(id).state, JobState::kRequeued);
  EXPECT_NE(job(id).reason.find("NODE_FAIL"), std::string::npos);
  slurm.set("102", "RUNNING");
  poll();
  slurm.set("102", "FAILED", 3, "NonZeroExitCode");
  poll();
  j = job(id);
  EXPECT_EQ(j.state, JobState::kFailed);  // the simulation's own error: no new attempt
  EXPECT_EQ(j.exitCode, 3);
  EXPECT_EQ(j.attempts, 3);
}

TEST_F(ManagerSlurmTest, RestartFollowsAndAdopts) {
  poll();
  const std::string running = manager->submit(submitRequest(1000, true)).value().id;
  slurm.set("100", "RUNNING");
  poll();
  // A second job whose sbatch went through but whose Slurm id was never recorded (the manager died in between).
  const std::string lost = manager->submit(submitRequest(1000, true)).value().id;
  Job j = job(lost);
  j.slurmJobId.clear();
  ASSERT_TRUE(store->save(j));
  manager.reset();
  makeManager();
  poll();
  EXPECT_EQ(job(running).state, JobState::kStarting);
  EXPECT_EQ(job(lost).slurmJobId, "101");  // adopted by its comment, not submitted twice
  EXPECT_EQ(slurm.submissions.size(), 2u);
  Progress end;
  end.step = end.totalSteps = 1000;
  end.time = end.duration = 1.0;
  ASSERT_TRUE(manager->reportProgress(running, end, "finished", 1));
  slurm.set("100", "COMPLETED");
  slurm.jobsById.erase("101");  // purged from slurmctld while the manager was away
  poll();
  EXPECT_EQ(job(lost).state, JobState::kQueued);  // one read without it may be a blip
  poll();
  EXPECT_EQ(job(running).state, JobState::kSucceeded);
  EXPECT_EQ(job(lost).state, JobState::kCancelled);
  EXPECT_NE(job(lost).reason.find("Slurm no longer knows job 101"), std::string::npos);
}

TEST_F(ManagerSlurmTest, ACompletedJobSucceedsWithoutItsLastReport) {
  poll();
  const std::string id = manager->submit(submitRequest(1000, true)).value().id;
  slurm.set("100", "RUNNING");
  poll();
  Progress p;
  p.step = 400;
  p.totalSteps = 1000;
  ASSERT_TRUE(manager->reportProgress(id, p, "", 1));
  slurm.set("100", "COMPLETED");  // exit 0: the worker finished; its last reports were lost (the manager was away)
  poll();
  EXPECT_EQ(job(id).state, JobState::kSucceeded);
  // A worker stopped by a SIGTERM that pflow did not send exits 143: another attempt goes on from the checkpoint.
  const std::string other = manager->submit(submitRequest(1000, true)).value().id;
  slurm.set("101", "RUNNING");
  poll();
  slurm.set("101", "FAILED", 143, "NonZeroExitCode");
  poll();
  EXPECT_EQ(job(other).state, JobState::kRequeued);
}

TEST_F(ManagerSlurmTest, AWorkerReportingBeforeThePollStartsItsJob) {
  poll();
  const std::string id = manager->submit(submitRequest(1000, true)).value().id;
  Progress p;
  p.step = 5;
  p.totalSteps = 1000;
  const auto stop = manager->reportProgress(id, p, "", 1);  // Slurm started it; the manager has not read that yet
  ASSERT_TRUE(stop);
  EXPECT_FALSE(stop.value());
  EXPECT_EQ(job(id).state, JobState::kRunning);
  slurm.set("100", "RUNNING");
  poll();
  EXPECT_EQ(job(id).devices.size(), 2u);  // the poll brings its devices
  EXPECT_TRUE(manager->reportProgress(id, p, "", 2).value());  // a worker of another attempt is told to stop
}

TEST_F(ManagerSlurmTest, DrainedNodesHoldJobsAndOrphansAreCancelled) {
  slurm.nodeList[0].state = "IDLE+DRAIN";
  poll();
  EXPECT_TRUE(manager->nodes()[0].lost);
  const std::string id = manager->submit(submitRequest(2000, true)).value().id;  // waits in Slurm, not refused
  EXPECT_EQ(job(id).state, JobState::kQueued);
  EXPECT_EQ(slurm.submissions.size(), 1u);
  {  // a Slurm job of pflow's whose pflow job ended (a scancel that failed): cancelled at the next read
    JobInfo stray;
    stray.id = "555";
    stray.state = "PENDING";
    stray.name = "pflow-job-000042";
    stray.comment = "pflow job-000042 attempt 1";
    slurm.jobsById["555"] = stray;
  }
  poll();
  EXPECT_NE(std::find(slurm.cancels.begin(), slurm.cancels.end(), "555"), slurm.cancels.end());
}

TEST_F(ManagerSlurmTest, RefusalsAndAnUnreachableSlurm) {
  poll();
  slurm.submitError = invalidArgument("sbatch: error: invalid partition specified: nosuch");
  const std::string a = manager->submit(submitRequest(1000, true)).value().id;
  EXPECT_EQ(job(a).state, JobState::kCancelled);
  EXPECT_NE(job(a).reason.find("refused by Slurm: sbatch: error: invalid partition"), std::string::npos);
  slurm.submitError = unavailable("sbatch: error: Unable to contact slurm controller");
  const std::string b = manager->submit(submitRequest(1000, true)).value().id;
  EXPECT_EQ(job(b).state, JobState::kQueued);
  EXPECT_NE(job(b).reason.find("Unable to contact slurm controller"), std::string::npos);
  slurm.submitError.reset();
  poll();
  EXPECT_EQ(job(b).slurmJobId, "100");
  // More memory than the node's four slots hold: never fits, refused before anything reaches Slurm.
  SubmitRequest big = submitRequest(1000, true);
  big.sceneYaml += "memory: 1e12\n";
  const auto refused = manager->submit(big);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(slurm.submissions.size(), 1u);
  HeartbeatInfo hb = testing::nodeBeat("x", 1);
  EXPECT_EQ(manager->heartbeat(hb).status().code(), StatusCode::kFailedPrecondition);  // agents have no part
}

}  // namespace
}  // namespace pflow::manager
