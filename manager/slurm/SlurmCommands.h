// The real SlurmClient: Slurm's own commands (sbatch, scontrol, scancel) run as processes with a deadline, on a
// host where they work (a login or service node: the cluster's slurm.conf, or SLURM_CONF, and its munge socket).
#pragma once
#include <string>

#include "manager/slurm/SlurmClient.h"

namespace pflow::manager::slurm {

struct CommandsConfig {
  std::string binDir;          // where sbatch, scontrol and scancel are ("" = PATH)
  double timeoutSeconds = 30;  // each command's deadline
};

class SlurmCommands final : public SlurmClient {
 public:
  explicit SlurmCommands(CommandsConfig config) : m_config(std::move(config)) {}
  Result<std::string> submit(const Submission& submission) override;
  Result<std::map<std::string, JobInfo>> jobs(const std::vector<std::string>& ids) override;
  Status cancel(const std::string& id) override;
  Result<std::vector<NodeInfo>> nodes() override;

  // The sbatch command line for a submission (tests).
  static std::vector<std::string> sbatchArgs(const Submission& s, const std::string& sbatch = "sbatch");

 private:
  std::string tool(const std::string& name) const;
  CommandsConfig m_config;
};

// An error message of a Slurm command as a Status: UNAVAILABLE when slurmctld cannot be reached, else `otherwise`.
Status slurmError(const std::string& command, const std::string& stderrText, StatusCode otherwise);

}  // namespace pflow::manager::slurm
