#include "manager/slurm/SlurmCommands.h"

#include <set>

#include "common/Log.h"
#include "manager/slurm/Command.h"
#include "manager/slurm/SlurmParse.h"

namespace pflow::manager::slurm {
namespace {

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

bool mentions(const std::string& text, const char* what) { return text.find(what) != std::string::npos; }

}  // namespace

Status slurmError(const std::string& command, const std::string& stderrText, StatusCode otherwise) {
  const std::string msg = log::escaped(trimmed(stderrText), 500);
  const bool unreachable = mentions(stderrText, "Unable to contact slurm controller") || mentions(stderrText, "Socket timed out") ||
                           mentions(stderrText, "Connection refused") || mentions(stderrText, "Munge") ||
                           mentions(stderrText, "munge") || mentions(stderrText, "Zero Bytes were transmitted");
  // Per-user limits of the service account (every pflow job is submitted as it): a later try may pass.
  const bool limit = mentions(stderrText, "QOSMax") || mentions(stderrText, "AssocMax") || mentions(stderrText, "MaxSubmit") ||
                     mentions(stderrText, "violates accounting/QOS policy");
  return Status(unreachable ? StatusCode::kUnavailable : limit ? StatusCode::kResourceExhausted : otherwise,
                command + ": " + (msg.empty() ? "failed" : msg));
}

std::string SlurmCommands::tool(const std::string& name) const {
  return m_config.binDir.empty() ? name : m_config.binDir + "/" + name;
}

std::vector<std::string> SlurmCommands::sbatchArgs(const Submission& s, const std::string& sbatch) {
  std::vector<std::string> a{sbatch, "--parsable", "--no-requeue", "--export=ALL", "--job-name=" + s.jobName,
                             "--ntasks=" + std::to_string(s.tasks), "--cpus-per-task=" + std::to_string(s.cpusPerTask),
                             "--output=" + s.logPath, "--chdir=" + s.workdir};
  if (s.gpusPerTask > 0) a.push_back("--gpus-per-task=" + std::to_string(s.gpusPerTask));
  if (!s.comment.empty()) a.push_back("--comment=" + s.comment);
  if (!s.partition.empty()) a.push_back("--partition=" + s.partition);
  if (!s.account.empty()) a.push_back("--account=" + s.account);
  if (!s.timeLimit.empty()) a.push_back("--time=" + s.timeLimit);
  a.push_back(s.scriptPath);
  return a;
}

Result<std::string> SlurmCommands::submit(const Submission& submission) {
  auto r = runCommand(sbatchArgs(submission, tool("sbatch")), m_config.timeoutSeconds);
  if (!r) return r.status().code() == StatusCode::kNotFound ? unavailable(r.status().message()) : r.status();
  if (r.value().exitCode != 0) return slurmError("sbatch", r.value().err, StatusCode::kInvalidArgument);
  std::string id = trimmed(r.value().out);
  if (const auto semi = id.find(';'); semi != std::string::npos) id.resize(semi);  // "ID;cluster"
  if (id.empty() || id.find_first_not_of("0123456789_") != std::string::npos)
    return internalError("sbatch answered '" + log::escaped(id, 80) + "', not a job id");
  return id;
}

Result<std::map<std::string, JobInfo>> SlurmCommands::jobs(const std::vector<std::string>& ids) {
  std::map<std::string, JobInfo> out;
  // One call for all of them: the detailed records of every job slurmctld keeps (running, pending, and finished
  // within MinJobAge), filtered here.
  auto r = runCommand({tool("scontrol"), "-o", "-d", "show", "job"}, m_config.timeoutSeconds);
  if (!r) return r.status().code() == StatusCode::kNotFound ? unavailable(r.status().message()) : r.status();
  if (r.value().exitCode != 0) {
    if (mentions(r.value().err, "No jobs in the system")) return out;
    return slurmError("scontrol show job", r.value().err, StatusCode::kInternal);
  }
  if (r.value().truncated)  // a partial list would make the jobs past the cut look gone
    return resourceExhausted("scontrol show job: more than 256 MiB of output; raise --slurm-poll or ask the site for a partition of pflow's own");
  const std::set<std::string> wanted(ids.begin(), ids.end());
  for (const Record& rec : parseRecords(r.value().out)) {
    JobInfo j = jobFromRecord(rec);
    if (ids.empty() || wanted.count(j.id)) out[j.id] = std::move(j);
  }
  return out;
}

Status SlurmCommands::cancel(const std::string& id) {
  auto r = runCommand({tool("scancel"), id}, m_config.timeoutSeconds);
  if (!r) return r.status().code() == StatusCode::kNotFound ? unavailable(r.status().message()) : r.status();
  if (r.value().exitCode == 0) return Status::ok();
  const std::string& err = r.value().err;
  if (mentions(err, "already completing or completed") || mentions(err, "Invalid job id")) return Status::ok();
  return slurmError("scancel " + id, err, StatusCode::kInternal);
}

Result<std::vector<NodeInfo>> SlurmCommands::nodes() {
  auto r = runCommand({tool("scontrol"), "-o", "show", "node"}, m_config.timeoutSeconds);
  if (!r) return r.status().code() == StatusCode::kNotFound ? unavailable(r.status().message()) : r.status();
  if (r.value().exitCode != 0) return slurmError("scontrol show node", r.value().err, StatusCode::kInternal);
  std::vector<NodeInfo> out;
  for (const Record& rec : parseRecords(r.value().out)) out.push_back(nodeFromRecord(rec));
  return out;
}

}  // namespace pflow::manager::slurm
