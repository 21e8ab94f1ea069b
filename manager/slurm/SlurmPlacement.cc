#include "manager/slurm/SlurmPlacement.h"

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <set>

namespace pflow::manager::slurm {
namespace {

bool hasWord(const std::string& state, const char* word) { return state.find(word) != std::string::npos; }

bool nodeUsable(const NodeInfo& n) {
  const std::string& s = n.state;
  return !(hasWord(s, "DOWN") || hasWord(s, "DRAIN") || hasWord(s, "FAIL") || hasWord(s, "NOT_RESPONDING") ||
           hasWord(s, "POWERED_DOWN") || hasWord(s, "FUTURE") || hasWord(s, "UNKNOWN") || hasWord(s, "INVAL"));
}

// Single quotes for bash: 'it'\''s'.
std::string quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

}  // namespace

std::vector<NodeView> nodeViews(const std::vector<NodeInfo>& nodes, const std::vector<JobInfo>& running,
                                const std::map<std::string, std::string>& pflowJobOf, const SlurmSettings& settings) {
  const std::string& wanted = settings.partition;
  std::map<DeviceKey, std::string> holder;
  for (const JobInfo& j : running) {
    const auto it = pflowJobOf.find(j.id);
    for (const DeviceKey& d : j.devices) holder[d] = it != pflowJobOf.end() ? it->second : "slurm:" + j.id;
  }
  std::vector<NodeView> out;
  for (const NodeInfo& n : nodes) {
    if (!wanted.empty() && std::find(n.partitions.begin(), n.partitions.end(), wanted) == n.partitions.end()) continue;
    NodeView v;
    v.name = n.name;
    v.agentAddress = "slurm";
    v.lost = !nodeUsable(n);
    v.slurmState = n.state;
    v.slurmReason = n.reason == "(null)" ? "" : n.reason;
    v.cpuLoad = n.cpuLoad;
    v.slurmPartitions = n.partitions;
    const bool gpus = n.gpus > 0;
    // A CPU job's rank takes cpusPerTask CPUs: that many make one slot.
    const int perSlot = std::max(1, settings.cpusPerTask);
    const int count = gpus ? n.gpus : n.cpus / perSlot;
    for (int i = 0; i < count; ++i) {
      DeviceView d;
      d.info.key = {n.name, i, gpus ? DeviceKind::kGpu : DeviceKind::kCpu};
      d.info.name = gpus ? "GPU" + (n.gpuType.empty() ? std::string() : " " + n.gpuType) + " (Slurm GRES)" : "CPU slot (Slurm)";
      d.info.memoryTotalBytes = gpus ? settings.gpuMemoryBytes : (count > 0 ? n.memoryBytes / std::uint64_t(count) : 0);
      d.info.utilization = gpus ? 0 : std::clamp(n.cpuLoad / std::max(1, n.cpus), 0.0, 1.0);
      if (v.lost) {
        d.state = DeviceState::kLost;
      } else if (auto it = holder.find(d.info.key); it != holder.end()) {
        d.state = DeviceState::kBusy;
        d.jobId = it->second;
      }
      v.devices.push_back(std::move(d));
    }
    // Jobs whose devices we could not see (a record without details) still count as busy, lowest free first.
    const int allocated = gpus ? n.gpusAllocated : (n.cpusAllocated + perSlot - 1) / perSlot;
    int busy = int(std::count_if(v.devices.begin(), v.devices.end(), [](const DeviceView& d) { return d.state == DeviceState::kBusy; }));
    for (DeviceView& d : v.devices) {
      if (busy >= allocated) break;
      if (d.state == DeviceState::kFree) {
        d.state = DeviceState::kBusy;
        d.jobId = "slurm";
        ++busy;
      }
    }
    out.push_back(std::move(v));
  }
  return out;
}

std::vector<NodeView> everyDevice(const std::vector<NodeView>& nodes, const std::string& partition) {
  std::vector<NodeView> out;
  for (const NodeView& n : nodes) {
    if (!partition.empty() && std::find(n.slurmPartitions.begin(), n.slurmPartitions.end(), partition) == n.slurmPartitions.end())
      continue;
    NodeView v = n;
    v.lost = false;  // a drained or powered-down node's devices still exist: Slurm holds the job until they return
    for (DeviceView& d : v.devices) {
      d.state = DeviceState::kFree;
      d.jobId.clear();
    }
    out.push_back(std::move(v));
  }
  return out;
}

Request requestFor(const Job& job, int attempt, const std::vector<NodeView>& nodes, const PlacementThresholds& thresholds,
                   const SlurmSettings& settings) {
  const std::string partition = job.slurm.partition.empty() ? settings.partition : job.slurm.partition;
  Request r;
  const std::vector<NodeView> all = everyDevice(nodes, partition);
  if (all.empty()) {
    r.reason = partition.empty() ? "Slurm shows this manager no nodes"
                                 : "partition '" + partition + "' has no nodes this manager shows (--slurm-partition)";
    return r;
  }
  const Placement p = place({job.particles, job.memoryBytes, job.maxDevices}, all, thresholds);
  if (p.outcome == PlacementOutcome::kNeverFits) {
    r.reason = p.reason;
    return r;
  }
  r.fits = true;
  r.kind = p.kind;
  Submission& s = r.submission;
  const std::string base = settings.workdir + "/" + job.id + "-" + std::to_string(attempt);
  s.jobName = "pflow-" + job.id;
  s.scriptPath = base + ".sbatch";
  s.logPath = base + ".log";
  s.workdir = settings.workdir;
  s.comment = commentFor(job.id, attempt);
  s.tasks = p.count;
  s.gpusPerTask = p.kind == DeviceKind::kGpu ? 1 : 0;
  s.cpusPerTask = p.kind == DeviceKind::kGpu ? 1 : std::max(1, settings.cpusPerTask);
  s.partition = job.slurm.partition.empty() ? settings.partition : job.slurm.partition;  // the scene's, else the manager's
  s.account = job.slurm.account.empty() ? settings.account : job.slurm.account;
  s.timeLimit = job.slurm.timeLimit.empty() ? settings.timeLimit : job.slurm.timeLimit;
  return r;
}

std::string batchScript(const Job& job, int attempt, DeviceKind kind, const std::string& managerAddress,
                        const std::string& backendAddress, const SlurmSettings& settings) {
  std::vector<std::string> worker{settings.workerPath, "--job-id", job.id, "--model", job.modelUri,
                                  "--devices", kind == DeviceKind::kGpu ? "slurm:gpu" : "slurm:cpu"};
  if (!managerAddress.empty()) worker.insert(worker.end(), {"--manager", managerAddress});
  if (!backendAddress.empty()) worker.insert(worker.end(), {"--backend", backendAddress});
  if (kind == DeviceKind::kCpu) worker.insert(worker.end(), {"--threads", std::to_string(std::max(1, settings.cpusPerTask))});
  if (attempt > 1) {
    worker.insert(worker.end(), {"--attempt", std::to_string(attempt)});
    if (!backendAddress.empty()) worker.push_back("--resume");  // from the job's last checkpoint on the back-end
  }
  worker.insert(worker.end(), settings.transportArgs.begin(), settings.transportArgs.end());
  std::string script = "#!/bin/bash\n# pflow " + job.id + ", attempt " + std::to_string(attempt) +
                       ": written by pflow-manager (--placement slurm). One worker rank per task, started by srun.\n";
  script += "exec srun --mpi=" + quoted(settings.mpi) + " --kill-on-bad-exit=1";
  for (const std::string& a : worker) script += " " + quoted(a);
  return script + "\n";
}

std::string commentFor(const std::string& jobId, int attempt) { return "pflow " + jobId + " attempt " + std::to_string(attempt); }

bool parseComment(const std::string& comment, std::string& jobId, int& attempt) {
  char id[80];
  int a = 0;
  if (std::sscanf(comment.c_str(), "pflow %79s attempt %d", id, &a) != 2 || a < 1) return false;
  jobId = id;
  attempt = a;
  return true;
}

Outcome outcomeOf(const JobInfo& j) {
  using K = Outcome::Kind;
  Outcome o;
  const std::string& s = j.state;
  const std::string reason = j.reason.empty() || j.reason == "None" ? "" : " (" + j.reason + ")";
  if (s == "PENDING" || s == "REQUEUED" || s == "REQUEUE_HOLD" || s == "REQUEUE_FED" || s == "RESV_DEL_HOLD") {
    o.kind = K::kPending;
    o.reason = j.reason.empty() || j.reason == "None" ? "pending" : j.reason;
    return o;
  }
  if (s == "RUNNING" || s == "CONFIGURING" || s == "COMPLETING" || s == "SUSPENDED" || s == "STOPPED" || s == "SIGNALING" ||
      s == "STAGE_OUT" || s == "RESIZING") {
    o.kind = K::kRunning;
    return o;
  }
  const int code = j.exitSignal > 0 ? 128 + j.exitSignal : j.exitCode;
  o.exitCode = code;
  const std::string exit = "exit code " + std::to_string(code);
  if (s == "COMPLETED") {
    o.kind = K::kSucceeded;
    return o;
  }
  if (s == "CANCELLED") {
    o.kind = K::kCancelled;
    o.reason = "cancelled in Slurm" + reason;
    return o;
  }
  if (s == "NODE_FAIL" || s == "PREEMPTED" || s == "BOOT_FAIL") {
    o.kind = K::kRequeue;
    o.reason = "Slurm ended the job: " + s + reason;
    return o;
  }
  if (s == "TIMEOUT" || s == "DEADLINE") {
    o.kind = K::kFailed;
    o.reason = "reached its Slurm time limit" + (j.timeLimit.empty() ? std::string() : " of " + j.timeLimit) + " (" + s + ")";
    return o;
  }
  if (s == "OUT_OF_MEMORY") {
    o.kind = K::kFailed;
    o.reason = "Slurm: OUT_OF_MEMORY (the job exceeded its memory)";
    return o;
  }
  // FAILED and anything else final: the worker's exit code decides, as under agents (Manager::reportExit). Killed
  // from outside (SIGKILL, SIGTERM, SIGHUP, SIGINT) or cut off from a service or its disk (2): another attempt may
  // succeed; its own error (1, 3, a crash) would repeat.
  const bool external = code == 2 || code == 128 + SIGKILL || code == 128 + SIGTERM || code == 128 + SIGHUP || code == 128 + SIGINT;
  o.kind = external ? K::kRequeue : K::kFailed;
  o.reason = "the worker failed with " + exit + " (Slurm: " + s + reason + ")";
  return o;
}

}  // namespace pflow::manager::slurm
