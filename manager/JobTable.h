// Jobs in memory and the legal state transitions. Not thread-safe: the Manager serialises access.
//
//   BUILDING   -> QUEUED (built and admitted), FAILED (invalid scene, refused), CANCELLED (cancel)
//   QUEUED     -> STARTING (placed), CANCELLED (cancel)
//   STARTING   -> RUNNING (start confirmed or first progress), SUCCEEDED/FAILED (exit, start failure, node lost),
//                 CANCELLING (cancel), REQUEUED (node lost, worker gone or killed, attempts left)
//   RUNNING    -> SUCCEEDED, FAILED, CANCELLING, REQUEUED
//   REQUEUED   -> STARTING (placed again), CANCELLED (cancel)
//   CANCELLING -> CANCELLED (worker exited, node lost, start failed)
//   SUCCEEDED, FAILED, CANCELLED: final.
#pragma once
#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "common/Status.h"
#include "manager/Types.h"

namespace pflow::manager {

class JobTable {
 public:
  static bool isLegal(JobState from, JobState to);

  // Applies a transition to a job value: state, reason, and the timestamps (startedAt when it leaves the queue,
  // finishedAt when it becomes final) and the attempt count (one more each time it leaves the queue). FAILED_PRECONDITION naming both states when the transition is illegal.
  static Status transition(Job& job, JobState to, const std::string& reason, double now);

  // Inserts or replaces a job (by id).
  void put(Job job);
  const Job* find(const std::string& id) const;
  // Every job in submission order; only queued/starting/running/cancelling ones when activeOnly.
  std::vector<Job> list(bool activeOnly) const;
  // Queued and requeued jobs, in submission order (the FIFO: a requeued job keeps its place).
  std::vector<const Job*> queued() const;
  // Jobs that hold devices (starting, running, cancelling).
  std::vector<const Job*> holdingDevices() const;
  // Removes a job (`pflow delete`); its seq stays used.
  void erase(const std::string& id);
  // The largest seq ever given (deleted jobs included, raiseSeq: the store remembers them), so ids never repeat.
  std::int64_t maxSeq() const { return m_maxSeq; }
  void raiseSeq(std::int64_t seq) { m_maxSeq = std::max(m_maxSeq, seq); }
  std::size_t size() const { return m_jobs.size(); }

 private:
  std::map<std::string, Job> m_jobs;
  std::map<std::int64_t, std::string> m_bySeq;
  std::int64_t m_maxSeq = 0;
};

}  // namespace pflow::manager
