// What pflow reads from and asks of Slurm, as plain data: a job's submission, a job's state as slurmctld reports
// it, a node. SlurmClient moves them; SlurmParse reads them from the commands' output. No gRPC, no processes.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "manager/Types.h"

namespace pflow::manager::slurm {

// One sbatch: the batch script and the resources of one pflow attempt.
struct Submission {
  std::string jobName;        // --job-name (pflow-<job id>)
  std::string scriptPath;     // the batch script (written by the caller)
  std::string logPath;        // --output (stdout and stderr of the script and its steps)
  std::string workdir;        // --chdir
  std::string comment;        // --comment: "pflow <job id> attempt N" (reconciliation after a manager restart)
  int tasks = 1;              // --ntasks: one MPI rank per device
  int gpusPerTask = 0;        // --gpus-per-task (0: a CPU job)
  int cpusPerTask = 1;        // --cpus-per-task
  std::string partition;      // --partition ("" = the cluster's default)
  std::string account;        // --account
  std::string timeLimit;      // --time, Slurm's formats ("" = the partition's limit)
};

// A job as slurmctld reports it (scontrol -o -d show job).
struct JobInfo {
  std::string id;
  std::string state;          // PENDING, RUNNING, COMPLETED, FAILED, CANCELLED, TIMEOUT, NODE_FAIL, ...
  std::string reason;         // why it pends or ended ("Resources", "Priority", "NonZeroExitCode", "None")
  int exitCode = 0;           // ExitCode=code:signal
  int exitSignal = 0;
  std::string comment;
  std::string name;           // JobName
  long userId = -1;           // UserId=name(uid)
  std::string stdOut;         // the script's log
  std::string timeLimit;
  std::vector<DeviceKey> devices;  // the allocation: per node its CPU ids, or its GPU indices when it has GPUs
};

// A node as slurmctld reports it (scontrol -o show node).
struct NodeInfo {
  std::string name;
  std::string address;
  std::string state;          // IDLE, MIXED, ALLOCATED, DOWN, DRAIN, ... (+ flags: IDLE+DRAIN)
  std::string reason;         // why it is down or drained
  int cpus = 0;
  int cpusAllocated = 0;
  int gpus = 0;               // gres/gpu in Gres=
  int gpusAllocated = 0;      // gres/gpu in AllocTRES=
  std::string gpuType;        // gpu:TYPE:N
  double cpuLoad = 0;
  std::uint64_t memoryBytes = 0;  // RealMemory (MB)
  std::vector<std::string> partitions;
};

}  // namespace pflow::manager::slurm
