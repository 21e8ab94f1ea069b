// Placement through Slurm (pflow-manager --placement slurm; manager/README.md, "Placement through Slurm"): the
// Manager's queue hands every queued attempt to Slurm at once (sbatch), Slurm's state of it is read back every
// SlurmSettings::pollSeconds (scontrol), and cancel is scancel. The rules that decide (device count, script, what a
// Slurm state means) are pure functions in slurm/SlurmPlacement.h.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "common/Log.h"
#include "common/LogTail.h"
#include "manager/Manager.h"
#include "manager/ManagerDetail.h"

namespace pflow::manager {
using namespace detail;

namespace {
// A requeued job's reason says why its last attempt ended; what Slurm does with the next one follows this marker.
constexpr const char* kPendingNote = "; now ";
std::string withoutPendingNote(const std::string& reason) {
  const auto at = reason.find(kPendingNote);
  return at == std::string::npos ? reason : reason.substr(0, at);
}
// The reason of a waiting job: `note` alone (queued), or after why its last attempt ended (requeued).
std::string waitingReason(const Job& job, const std::string& note) {
  return job.state == JobState::kRequeued ? withoutPendingNote(job.reason) + kPendingNote + note : note;
}
}  // namespace

void Manager::scheduleSlurmLocked(Actions& actions) {
  if (!m_slurmNodesKnown) return;  // the first poll has not read the nodes yet: the count needs them
  const slurm::SlurmSettings& settings = *m_options.slurm;
  std::vector<std::string> queue;
  for (const Job* j : m_jobs.queued())
    if (j->slurmJobId.empty() && !m_submitting.count(j->id)) queue.push_back(j->id);
  for (const std::string& id : queue) {
    const Job job = *m_jobs.find(id);
    const int attempt = job.attempts + 1;
    const slurm::Request req = slurm::requestFor(job, attempt, m_slurmNodes, m_options.thresholds, settings);
    if (!req.fits) {
      // QUEUED cannot go to FAILED directly: Slurm has nothing of it, so it is cancelled with the refusal as reason.
      endLocked(job, JobState::kCancelled, "refused: " + req.reason, std::nullopt, "refused: " + req.reason);
      continue;
    }
    Action a{Action::Kind::kSubmit, id, "", {}, req.submission, {}};
    a.script = slurm::batchScript(job, attempt, req.kind, m_options.managerAddress, m_options.backendAddress, settings);
    m_submitting.insert(id);
    actions.push_back(std::move(a));
  }
}

Result<std::string> Manager::submitToSlurm(const Action& a) {
  std::error_code ec;
  std::filesystem::create_directories(m_options.slurm->workdir, ec);
  {
    std::ofstream out(a.submission.scriptPath, std::ios::trunc);
    out << a.script;
    if (!out.flush()) return ioError("cannot write the batch script " + a.submission.scriptPath);
  }
  std::filesystem::permissions(a.submission.scriptPath, std::filesystem::perms::owner_all, std::filesystem::perm_options::add, ec);
  return m_slurm->submit(a.submission);
}

void Manager::applySubmit(const Action& a, const Result<std::string>& r, Actions& more) {
  m_submitting.erase(a.jobId);
  const Job* j = m_jobs.find(a.jobId);
  if (!j) return;
  if (!r) {
    const std::string why = r.status().message();
    if (r.status().code() == StatusCode::kUnavailable || r.status().code() == StatusCode::kDeadlineExceeded ||
        r.status().code() == StatusCode::kIo || r.status().code() == StatusCode::kResourceExhausted) {
      // Slurm out of reach, the work folder, or a submit limit of the service account: tried again at the next poll
      // (a timed-out sbatch that Slurm took is adopted by its comment first); the job says why it waits.
      if (isWaiting(j->state) && j->reason != waitingReason(*j, "waiting: " + why)) {
        Job next = *j;
        next.reason = waitingReason(*j, "waiting: " + why);
        (void)commitLocked(next, "waiting: " + why);
      }
      return;
    }
    if (isWaiting(j->state))
      endLocked(*j, JobState::kCancelled, "refused by Slurm: " + why, std::nullopt, "refused by Slurm: " + why);
    return;
  }
  const std::string slurmId = r.value();
  if (!isWaiting(j->state)) {  // cancelled while sbatch ran: the Slurm job has no pflow job to run for
    more.push_back({Action::Kind::kStop, a.jobId, slurmId, {}, {}, {}});
    return;
  }
  if (!j->slurmJobId.empty()) {  // adopted by a poll while sbatch answered: the same job
    if (j->slurmJobId != slurmId) more.push_back({Action::Kind::kStop, a.jobId, slurmId, {}, {}, {}});
    return;
  }
  Job next = *j;
  next.slurmJobId = slurmId;
  m_slurmRecordedAt[a.jobId] = m_clock.now();
  next.reason = waitingReason(*j, "submitted to Slurm as job " + slurmId);
  (void)commitLocked(next, "submitted to Slurm as job " + slurmId + " (" + std::to_string(a.submission.tasks) + " task(s)" +
                               (a.submission.gpusPerTask > 0 ? ", one GPU each" : "") + ")");
}

void Manager::pollSlurm() {
  std::unique_lock pollLock(m_pollMu, std::try_to_lock);
  if (!pollLock.owns_lock()) return;
  double began = 0;
  {
    std::lock_guard lock(m_mu);
    if (m_clock.now() - m_slurmPolledAt < m_options.slurm->pollSeconds) return;
    m_slurmPolledAt = began = m_clock.now();
  }
  auto nodes = m_slurm->nodes();
  auto jobs = nodes ? m_slurm->jobs({}) : Result<std::map<std::string, slurm::JobInfo>>(nodes.status());
  if (!nodes || !jobs) {
    const Status& s = !nodes ? nodes.status() : jobs.status();
    spdlog::warn("manager: reading Slurm's nodes and jobs: {} (tried again in {})", s.toString(), seconds(m_options.slurm->pollSeconds));
    return;
  }
  std::vector<slurm::JobInfo> all;
  for (auto& [id, info] : jobs.value()) all.push_back(std::move(info));
  Actions actions;
  {
    std::lock_guard lock(m_mu);
    applySlurmLocked(all, nodes.value(), began, actions);
  }
  runActions(std::move(actions));
}

Job Manager::startedFromSlurmLocked(const Job& job, const slurm::JobInfo& info) {
  Job next = job;
  (void)JobTable::transition(next, JobState::kStarting, "", m_clock.now());
  next.devices = info.devices;
  next.reason = job.state == JobState::kRequeued ? withoutPendingNote(job.reason) : "";  // a requeued job keeps why
  (void)commitLocked(next, "starting: Slurm job " + info.id + " runs on " + (next.devices.empty() ? "its nodes" : describeDevices(next.devices)));
  m_runtime[next.id].attached = true;
  return *m_jobs.find(next.id);
}

void Manager::applySlurmJobLocked(const Job& job, const slurm::JobInfo* info) {
  using K = slurm::Outcome::Kind;
  const std::string sid = job.slurmJobId;
  if (info) m_slurmMissing.erase(job.id);
  if (!info && ++m_slurmMissing[job.id] < 2) return;  // one read without it may be a blip: ask again
  if (!info) {
    m_slurmMissing.erase(job.id);
    // slurmctld forgot it (finished longer ago than its MinJobAge while the manager was away) or never had it.
    const std::string why = "Slurm no longer knows job " + sid + " (it ended longer ago than slurmctld keeps jobs)";
    if (job.state == JobState::kCancelling || isWaiting(job.state)) endLocked(job, JobState::kCancelled, why, std::nullopt, "cancelled: " + why);
    else endLocked(job, JobState::kFailed, why, std::nullopt, "failed: " + why);
    return;
  }
  const slurm::Outcome o = slurm::outcomeOf(*info);
  if (o.kind == K::kPending) {
    // A requeued job keeps why its last attempt ended, with Slurm's word on the new one after it.
    const std::string pending = "waiting in Slurm as job " + sid + ": " + o.reason;
    const std::string reason = waitingReason(job, pending);
    if (isWaiting(job.state) && job.reason != reason) {
      Job next = job;
      next.reason = reason;
      (void)commitLocked(next, reason);
    }
    return;
  }
  if (o.kind == K::kRunning) {
    if (isWaiting(job.state)) {
      startedFromSlurmLocked(job, *info);
    } else if (job.devices.empty() && !info->devices.empty() && holdsDevices(job.state)) {  // started by its first report
      Job next = job;
      next.devices = info->devices;
      (void)commitLocked(next, "running on " + describeDevices(next.devices));
    }
    return;
  }
  // Final in Slurm.
  if (job.state == JobState::kCancelling || (isWaiting(job.state) && o.kind == K::kCancelled)) {
    endLocked(job, JobState::kCancelled, job.state == JobState::kCancelling ? "" : o.reason, o.exitCode,
              "cancelled (Slurm job " + sid + " " + info->state + ")");
    return;
  }
  const Job& started = isWaiting(job.state) ? startedFromSlurmLocked(job, *info) : job;  // it ran between two polls
  std::string why = o.reason;
  if (o.kind == K::kFailed || o.kind == K::kRequeue) {
    const std::string line = lastErrorLine(info->stdOut);
    if (!line.empty()) why += ": " + log::escaped(line, 400);
  }
  switch (o.kind) {
    case K::kSucceeded:
      // Exit 0: the worker reached its end (one stopped by a signal pflow did not send exits 143, and the manager's
      // own cancel ended above), whether or not its last progress report got here (the manager may have been away).
      endLocked(started, JobState::kSucceeded, "", 0, "succeeded (Slurm job " + sid + " COMPLETED)");
      break;
    case K::kCancelled:
      endLocked(started, JobState::kFailed, why + ": scancel from outside pflow", o.exitCode, "failed: " + why);
      break;
    case K::kFailed: endLocked(started, JobState::kFailed, why + " [Slurm job " + sid + "]", o.exitCode, "failed: " + why); break;
    case K::kRequeue: {
      Job next = started;
      next.slurmJobId.clear();  // the next attempt is a new Slurm job
      requeueOrFailLocked(next, why + " [Slurm job " + sid + "]", o.exitCode);
      break;
    }
    default: break;
  }
}

void Manager::applySlurmLocked(const std::vector<slurm::JobInfo>& jobs, const std::vector<slurm::NodeInfo>& nodes, double began,
                               Actions& actions) {
  std::map<std::string, const slurm::JobInfo*> byId;
  for (const slurm::JobInfo& j : jobs) byId[j.id] = &j;

  // pflow's own Slurm jobs: submitted by this service account, named and commented by the manager.
  const long uid = long(::geteuid());
  for (const slurm::JobInfo& info : jobs) {
    std::string id;
    int attempt = 0;
    if (!slurm::parseComment(info.comment, id, attempt) || info.name != "pflow-" + id || (info.userId >= 0 && info.userId != uid))
      continue;
    const Job* j = m_jobs.find(id);
    const auto kind = slurm::outcomeOf(info).kind;
    const bool active = kind == slurm::Outcome::Kind::kPending || kind == slurm::Outcome::Kind::kRunning;
    if (j && isWaiting(j->state) && j->slurmJobId.empty() && !m_submitting.count(id) && attempt == j->attempts + 1 && active) {
      // An attempt that was submitted but not recorded (the manager stopped, or sbatch timed out after Slurm took
      // it): adopted, never submitted twice.
      Job next = *j;
      next.slurmJobId = info.id;
      m_slurmRecordedAt[id] = m_clock.now();
      (void)commitLocked(next, "adopted Slurm job " + info.id + " (submitted, but its id was not recorded)");
    } else if (active && !m_submitting.count(id) && (!j || isFinal(j->state) || (!j->slurmJobId.empty() && j->slurmJobId != info.id))) {
      // A Slurm job no pflow attempt owns (its job ended, or a scancel that failed): it would only hold devices.
      actions.push_back({Action::Kind::kStop, id, info.id, {}, {}, {}});
    }
  }

  // Final states first: a job that ended frees devices another may start on in the same poll.
  std::vector<std::string> ids;
  for (const Job* j : m_jobs.holdingDevices()) ids.push_back(j->id);
  for (const Job* j : m_jobs.queued()) ids.push_back(j->id);
  std::stable_partition(ids.begin(), ids.end(), [&](const std::string& id) {
    const Job& j = *m_jobs.find(id);
    const auto it = byId.find(j.slurmJobId);
    return it == byId.end() || slurm::outcomeOf(*it->second).kind != slurm::Outcome::Kind::kRunning;
  });
  for (const std::string& id : ids) {
    const Job* j = m_jobs.find(id);
    if (!j || j->slurmJobId.empty() || isFinal(j->state)) continue;
    const auto it = byId.find(j->slurmJobId);
    const auto recorded = m_slurmRecordedAt.find(id);
    if (it == byId.end() && recorded != m_slurmRecordedAt.end() && recorded->second >= began)
      continue;  // recorded after this read of Slurm began: it may not be in it yet
    const Job job = *j;
    applySlurmJobLocked(job, it == byId.end() ? nullptr : it->second);
  }

  std::map<std::string, std::string> pflowJobOf;
  for (const Job* j : m_jobs.holdingDevices())
    if (!j->slurmJobId.empty()) pflowJobOf[j->slurmJobId] = j->id;
  std::vector<slurm::JobInfo> running;
  for (const slurm::JobInfo& j : jobs)
    if (slurm::outcomeOf(j).kind == slurm::Outcome::Kind::kRunning) running.push_back(j);
  m_slurmNodes = slurm::nodeViews(nodes, running, pflowJobOf, *m_options.slurm);
  m_slurmNodesKnown = true;
  scheduleLocked(actions);
}

}  // namespace pflow::manager
