// What the manager asks of Slurm. SlurmCommands is the real one (sbatch, scontrol, scancel); tests of the
// Manager use a fake. Implementations must be thread-safe and give every call a deadline.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "common/Status.h"
#include "manager/slurm/SlurmTypes.h"

namespace pflow::manager::slurm {

class SlurmClient {
 public:
  virtual ~SlurmClient() = default;
  // Submits the batch job; returns Slurm's job id. INVALID_ARGUMENT with sbatch's message when Slurm refuses it
  // (an unknown partition or account, a request no node can ever hold); UNAVAILABLE when slurmctld is out of reach.
  virtual Result<std::string> submit(const Submission& submission) = 0;
  // The jobs slurmctld knows among `ids` (every job it knows when `ids` is empty; a finished job stays known for
  // MinJobAge). A job absent from the result is unknown to slurmctld (purged, or never existed).
  virtual Result<std::map<std::string, JobInfo>> jobs(const std::vector<std::string>& ids) = 0;
  // scancel: SIGTERM to its steps, then SIGKILL after KillWait. A job already ended is not an error.
  virtual Status cancel(const std::string& id) = 0;
  virtual Result<std::vector<NodeInfo>> nodes() = 0;
};

}  // namespace pflow::manager::slurm
