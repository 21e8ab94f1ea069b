// Placement through Slurm, as pure functions the Manager calls (manager/README.md, "Placement through Slurm"):
// Slurm's nodes as pflow's node views, a job's request (the patent's device count from its particles and the
// devices that exist), the batch script that starts its worker with srun, and Slurm's job states mapped to
// what becomes of the pflow job.
#pragma once
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "manager/Placement.h"
#include "manager/Types.h"
#include "manager/slurm/SlurmTypes.h"

namespace pflow::manager::slurm {

// The manager's settings for placement through Slurm (pflow-manager --placement slurm, --slurm-*).
struct SlurmSettings {
  std::string workdir;            // batch scripts and workers' logs: a folder every node sees at the same path
  std::string workerPath = "pflow-worker";
  std::vector<std::string> transportArgs;  // --tls-dir DIR or --insecure, passed on to workers
  std::string mpi = "pmix";       // srun --mpi
  std::string partition;          // defaults for every job ("" = the cluster's)
  std::string account;
  std::string timeLimit;
  std::uint64_t gpuMemoryBytes = 0;     // GRES says nothing of a GPU's memory; 0 = unknown (no memory minimum)
  int cpusPerTask = 1;            // each rank of a CPU job (its OpenMP threads)
  double pollSeconds = 2;         // how often jobs and nodes are read from slurmctld
};

// Slurm's nodes as node views: a node with GPUs (GRES gpu) shows them, others their CPUs as slots. A device is BUSY
// when a job of `running` holds it (with the pflow job's id when `pflowJobOf` names one, else "slurm:<id>"); a
// node that is down, drained, failing or not responding is lost. Nodes outside `settings.partition`, when
// set, are left out.
std::vector<NodeView> nodeViews(const std::vector<NodeInfo>& nodes, const std::vector<JobInfo>& running,
                                const std::map<std::string, std::string>& pflowJobOf, const SlurmSettings& settings);

// `nodes` as they count for a job's device count: those of `partition` ("" = all), every device free and no node
// lost (Slurm queues the job until its devices are free and its nodes back).
std::vector<NodeView> everyDevice(const std::vector<NodeView>& nodes, const std::string& partition);

// The request for one attempt of `job`: the device count and kind by the manager's rule (Placement.h) over every
// device that exists in its partition (the scene's, else the manager's), or the reason it can never fit.
struct Request {
  bool fits = false;
  std::string reason;     // when it never fits
  Submission submission;  // when it fits (scriptPath and logPath under settings.workdir)
  DeviceKind kind = DeviceKind::kGpu;
};
Request requestFor(const Job& job, int attempt, const std::vector<NodeView>& nodes, const PlacementThresholds& thresholds,
                   const SlurmSettings& settings);

// The batch script: srun starts one worker rank per task; the worker finds its device from Slurm's environment
// (pflow-worker --devices slurm:gpu|slurm:cpu). `attempt` > 1 resumes from the job's last checkpoint.
std::string batchScript(const Job& job, int attempt, DeviceKind kind, const std::string& managerAddress,
                        const std::string& backendAddress, const SlurmSettings& settings);

// The comment that ties a Slurm job to a pflow attempt ("pflow job-000001 attempt 2"), and its reading.
std::string commentFor(const std::string& jobId, int attempt);
bool parseComment(const std::string& comment, std::string& jobId, int& attempt);

// What Slurm's state of a job means for the pflow job.
struct Outcome {
  enum class Kind {
    kPending,    // queued in Slurm: `reason` is Slurm's (Resources, Priority, ...)
    kRunning,    // allocated (running, configuring, completing, suspended)
    kSucceeded,  // COMPLETED
    kFailed,     // the job's own failure: it would repeat (exit code 1 or 3, a crash, a time limit, out of memory)
    kRequeue,    // not the job's fault: NODE_FAIL, PREEMPTED, BOOT_FAIL, or the worker killed from outside / cut off
    kCancelled,  // CANCELLED
  } kind = Kind::kPending;
  std::string reason;
  std::optional<int> exitCode;
};
Outcome outcomeOf(const JobInfo& info);

}  // namespace pflow::manager::slurm
