#include "manager/JobTable.h"

namespace pflow::manager {

bool JobTable::isLegal(JobState from, JobState to) {
  using S = JobState;
  switch (from) {
    case S::kQueued:
    case S::kRequeued: return to == S::kStarting || to == S::kCancelled;
    case S::kBuilding: return to == S::kQueued || to == S::kFailed || to == S::kCancelled;
    case S::kStarting:
      return to == S::kRunning || to == S::kSucceeded || to == S::kFailed || to == S::kCancelling || to == S::kRequeued;
    case S::kRunning: return to == S::kSucceeded || to == S::kFailed || to == S::kCancelling || to == S::kRequeued;
    case S::kCancelling: return to == S::kCancelled;
    case S::kSucceeded:
    case S::kFailed:
    case S::kCancelled: return false;
  }
  return false;
}

Status JobTable::transition(Job& job, JobState to, const std::string& reason, double now) {
  if (!isLegal(job.state, to))
    return failedPrecondition("job " + job.id + " cannot go from " + jobStateName(job.state) + " to " + jobStateName(to));
  if (isWaiting(job.state) && to == JobState::kStarting) {
    job.startedAt = now;
    ++job.attempts;
  }
  job.state = to;
  if (!reason.empty()) job.reason = reason;
  if (isFinal(to)) job.finishedAt = now;
  return Status::ok();
}

void JobTable::put(Job job) {
  m_bySeq[job.seq] = job.id;
  raiseSeq(job.seq);
  const std::string id = job.id;
  m_jobs[id] = std::move(job);
}

void JobTable::erase(const std::string& id) {
  auto it = m_jobs.find(id);
  if (it == m_jobs.end()) return;
  m_bySeq.erase(it->second.seq);
  m_jobs.erase(it);
}

const Job* JobTable::find(const std::string& id) const {
  auto it = m_jobs.find(id);
  return it == m_jobs.end() ? nullptr : &it->second;
}

std::vector<Job> JobTable::list(bool activeOnly) const {
  std::vector<Job> out;
  for (const auto& [seq, id] : m_bySeq) {
    const Job& j = m_jobs.at(id);
    if (!activeOnly || !isFinal(j.state)) out.push_back(j);
  }
  return out;
}

std::vector<const Job*> JobTable::queued() const {
  std::vector<const Job*> out;
  for (const auto& [seq, id] : m_bySeq) {
    const Job& j = m_jobs.at(id);
    if (isWaiting(j.state)) out.push_back(&j);
  }
  return out;
}

std::vector<const Job*> JobTable::holdingDevices() const {
  std::vector<const Job*> out;
  for (const auto& [seq, id] : m_bySeq) {
    const Job& j = m_jobs.at(id);
    if (holdsDevices(j.state)) out.push_back(&j);
  }
  return out;
}

}  // namespace pflow::manager
