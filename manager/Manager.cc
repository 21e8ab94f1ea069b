#include "manager/Manager.h"

#include <spdlog/spdlog.h>

#include <csignal>
#include <cstdio>
#include <set>

#include "common/Address.h"
#include "common/Log.h"
#include "manager/ManagerDetail.h"

namespace pflow::manager {
using namespace detail;


Manager::Manager(ManagerOptions options, const Clock& clock, JobStore& store, AgentClient& agents, FrontendClient& frontend)
    : m_options(std::move(options)),
      m_clock(clock),
      m_store(store),
      m_agents(agents),
      m_frontend(frontend),
      m_inventory(clock, m_options.heartbeatTimeoutSeconds, m_options.forgetLostNodeSeconds) {}

Result<std::unique_ptr<Manager>> Manager::create(ManagerOptions options, const Clock& clock, JobStore& store,
                                                 AgentClient& agents, FrontendClient& frontend, slurm::SlurmClient* slurm) {
  if (!(options.heartbeatTimeoutSeconds > 0) || !(options.heartbeatIntervalSeconds > 0) || !(options.missingJobGraceSeconds > 0))
    return invalidArgument("manager: heartbeat timeout, interval and missing-job grace must be positive");
  if (options.maxAttempts < 1) return invalidArgument("manager: --max-attempts must be at least 1 (" + std::to_string(options.maxAttempts) + ")");
  if (options.thresholds.particlesPerGpu == 0 || options.thresholds.particlesPerCpuSlot == 0)
    return invalidArgument("manager: particles per GPU and per CPU slot must be positive");
  if (options.slurm && !slurm) return invalidArgument("manager: placement through Slurm needs a Slurm client");
  if (options.slurm && options.slurm->workdir.empty())
    return invalidArgument("manager: placement through Slurm needs a work folder every node sees (--slurm-workdir)");
  std::unique_ptr<Manager> m(new Manager(std::move(options), clock, store, agents, frontend));
  if (m->m_options.slurm) m->m_slurm = slurm;
  auto jobs = store.loadAll();
  if (!jobs) return jobs.status();
  int active = 0, queued = 0;
  for (Job& j : jobs.value()) {
    if (j.state == JobState::kBuilding) {  // its build was lost with the manager that ran it
      (void)JobTable::transition(j, JobState::kFailed, "the manager stopped while the scene was being built: submit it again", clock.now());
      if (Status s = store.save(j); !s) return s;
    }
    if (holdsDevices(j.state)) {
      if (Status s = m->m_inventory.lease(j.devices, j.id); !s) return internalError("job database " + store.path() + ": " + s.message());
      m->m_runtime[j.id].attached = true;  // whatever the agent says at its next heartbeat decides
      ++active;
    } else if (isWaiting(j.state)) {
      ++queued;
    }
    m->m_jobs.put(std::move(j));
  }
  auto maxSeq = store.maxSeqEver();
  if (!maxSeq) return maxSeq.status();
  m->m_jobs.raiseSeq(maxSeq.value());
  m->m_loadedAt = clock.now();
  spdlog::info("manager: loaded {} jobs from {} ({} queued, {} holding devices: they re-attach when their agents heartbeat)",
               m->m_jobs.size(), store.path(), queued, active);
  return m;
}

// ---- state changes -----------------------------------------------------------------------------------------------

Status Manager::commitLocked(Job next, const std::string& event) {
  if (Status s = m_store.save(next); !s) {
    spdlog::error("manager: {}", s.toString());
    return s;
  }
  if (holdsDevices(next.state)) {
    if (Status s = m_inventory.lease(next.devices, next.id); !s) spdlog::error("manager: {}", s.message());
  } else {
    m_inventory.release(next.id);
    m_runtime.erase(next.id);
  }
  const Job* prev = m_jobs.find(next.id);
  if (!prev || prev->state != next.state)
    spdlog::info("manager: {} {}{}", next.id, jobStateName(next.state), next.reason.empty() ? "" : " (" + log::escaped(next.reason, 500) + ")");
  publishLocked(next, event);
  return Status::ok();
}

void Manager::publishLocked(const Job& next, const std::string& event) {
  m_jobs.put(next);
  const Job& job = *m_jobs.find(next.id);
  const JobEvent ev{job, event};
  for (auto it = m_watchers.begin(); it != m_watchers.end();) {
    if (it->second.jobId == job.id) {
      it->second.callback(ev);
      if (isFinal(job.state)) {
        it = m_watchers.erase(it);
        continue;
      }
    }
    ++it;
  }
}

void Manager::endLocked(const Job& job, JobState to, const std::string& reason, std::optional<int> exitCode, const std::string& event) {
  Job next = job;
  if (Status s = JobTable::transition(next, to, reason, m_clock.now()); !s) {
    spdlog::error("manager: {}", s.message());
    return;
  }
  if (exitCode) next.exitCode = *exitCode;
  (void)commitLocked(std::move(next), event);
}

void Manager::requeueOrFailLocked(const Job& job, const std::string& why, std::optional<int> exitCode) {
  const int limit = job.maxAttempts > 0 ? job.maxAttempts : m_options.maxAttempts;
  const std::string attempt = "attempt " + std::to_string(job.attempts) + " of " + std::to_string(limit);
  if (job.attempts >= limit) {
    endLocked(job, JobState::kFailed, why + " (" + attempt + ")", exitCode, "failed: " + why + " (" + attempt + ", none left)");
    return;
  }
  Job next = job;
  next.message.clear();  // the last attempt's progress message
  endLocked(next, JobState::kRequeued, why + " (" + attempt + "; requeued)", exitCode, "requeued: " + why + " (" + attempt + ")");
}

Lease Manager::leaseFor(const Job& job) const {
  Lease l;
  l.jobId = job.id;
  l.modelUri = job.modelUri;
  l.devices = job.devices;
  for (const std::string& node : nodesOf(job)) l.nodeHosts[node] = pflow::hostOf(m_inventory.agentAddress(node));
  l.managerAddress = m_options.managerAddress;
  l.backendAddress = m_options.backendAddress;
  l.attempt = job.attempts > 0 ? job.attempts : 1;
  return l;
}

void Manager::stopAction(const Job& job, Actions& actions) const {
  if (usesSlurm()) {
    if (!job.slurmJobId.empty()) actions.push_back({Action::Kind::kStop, job.id, job.slurmJobId, {}, {}, {}});
    return;
  }
  const std::string lead = leadNode(job);
  if (lead.empty() || !m_inventory.isKnown(lead) || m_inventory.isLost(lead)) return;
  actions.push_back({Action::Kind::kStop, job.id, m_inventory.agentAddress(lead), {}, {}, {}});
}

void Manager::scheduleLocked(Actions& actions) {
  if (usesSlurm()) return scheduleSlurmLocked(actions);
  std::vector<std::string> queue;
  for (const Job* j : m_jobs.queued()) queue.push_back(j->id);
  for (const std::string& id : queue) {
    const Job& job = *m_jobs.find(id);
    const Placement p = place({job.particles, job.memoryBytes, job.maxDevices}, m_inventory.snapshot(), m_options.thresholds);
    if (p.outcome != PlacementOutcome::kPlaced) break;  // FIFO: the head of the queue waits, and so does everyone behind it
    Job next = job;
    if (next.state == JobState::kQueued) next.reason.clear();  // a requeued job keeps why its last attempt ended
    (void)JobTable::transition(next, JobState::kStarting, "", m_clock.now());
    next.devices = p.devices;
    if (!commitLocked(next, "starting on " + describeDevices(p.devices))) break;
    m_runtime[id] = Runtime{};
    const Job& started = *m_jobs.find(id);
    actions.push_back({Action::Kind::kStart, id, m_inventory.agentAddress(leadNode(started)), leaseFor(started), {}, {}});
  }
}

void Manager::runActions(Actions actions) {
  while (!actions.empty()) {
    Action a = std::move(actions.front());
    actions.erase(actions.begin());
    Actions more;
    if (a.kind == Action::Kind::kSubmit) {
      const auto r = submitToSlurm(a);
      std::lock_guard lock(m_mu);
      applySubmit(a, r, more);
    } else if (a.kind == Action::Kind::kStart) {
      const auto r = m_agents.startJob(a.address, a.lease);
      std::lock_guard lock(m_mu);
      applyStart(a, r, more);
    } else {
      const Status s = usesSlurm() ? m_slurm->cancel(a.address) : m_agents.stopJob(a.address, a.jobId);
      std::lock_guard lock(m_mu);
      applyStop(a, s, more);
    }
    for (Action& m : more) actions.push_back(std::move(m));
  }
}

void Manager::applyStart(const Action& a, const Result<std::int64_t>& r, Actions& more) {
  const Job* job = m_jobs.find(a.jobId);
  if (!job) return;
  const bool started = r.isOk() || r.status().code() == StatusCode::kAlreadyExists;
  if (started) {
    if (auto it = m_runtime.find(a.jobId); it != m_runtime.end()) it->second.attached = true;
    const std::string pid = r.isOk() ? " (pid " + std::to_string(r.value()) + ")" : "";
    if (job->state == JobState::kStarting) {
      Job next = *job;
      (void)JobTable::transition(next, JobState::kRunning, "", m_clock.now());
      (void)commitLocked(next, "running on " + describeDevices(next.devices) + pid);
    } else if (job->state == JobState::kCancelling || isFinal(job->state)) {
      stopAction(*job, more);  // cancelled or ended while it was being started
    }
    return;
  }
  const std::string why = "the agent on node " + leadNode(*job) + " could not start the job: " + r.status().message();
  if (job->state == JobState::kStarting) {
    endLocked(*job, JobState::kFailed, why, std::nullopt, "failed: " + why);
  } else if (job->state == JobState::kCancelling) {
    endLocked(*job, JobState::kCancelled, "", std::nullopt, "cancelled before it started (" + why + ")");
  } else {
    return;  // running (a progress report came first) or already ended: the start answer changes nothing
  }
  scheduleLocked(more);
}

void Manager::applyStop(const Action& a, const Status& s, Actions& more) {
  if (s) return;  // the exit report (agents) or Slurm's final state (Slurm) finishes the job
  if (usesSlurm()) {
    spdlog::warn("manager: scancel {} for {}: {} (asked again at the next cancel)", a.address, a.jobId, s.toString());
    return;
  }
  const Job* job = m_jobs.find(a.jobId);
  if (!job) return;
  if (s.code() == StatusCode::kNotFound && job->state == JobState::kCancelling) {
    auto it = m_runtime.find(a.jobId);
    if (it != m_runtime.end() && it->second.attached) {
      endLocked(*job, JobState::kCancelled, "", std::nullopt, "cancelled (its agent no longer ran the worker)");
      scheduleLocked(more);
    }
    return;
  }
  spdlog::warn("manager: stopping {} at {}: {} (retried through the agent's heartbeats)", a.jobId, a.address, s.toString());
}

// ---- agents and workers ------------------------------------------------------------------------------------------

Result<HeartbeatReply> Manager::heartbeat(const HeartbeatInfo& hb) {
  if (Status s = Inventory::validateHeartbeat(hb); !s) return s;
  if (usesSlurm())
    return failedPrecondition("this manager places jobs through Slurm (--placement slurm): node agents have no part; stop the agent on " +
                              hb.node);
  HeartbeatReply reply;
  reply.heartbeatIntervalSeconds = m_options.heartbeatIntervalSeconds;
  Actions actions;
  {
    std::lock_guard lock(m_mu);
    const double now = m_clock.now();
    if (m_inventory.heartbeat(hb))
      spdlog::info("manager: node {} at {} joined with {} device(s)", hb.node, hb.agentAddress, hb.devices.size());
    const std::set<std::string> running(hb.runningJobs.begin(), hb.runningJobs.end());
    for (const std::string& id : running) {
      const Job* j = m_jobs.find(id);
      // Ended, cancelling, waiting in the queue, or started again on other devices (a worker of an earlier attempt).
      if (!j || isFinal(j->state) || j->state == JobState::kCancelling || isWaiting(j->state) || !nodesOf(*j).count(hb.node))
        reply.stopJobs.push_back(id);
    }
    std::vector<std::string> held;
    for (const Job* j : m_jobs.holdingDevices())
      if (leadNode(*j) == hb.node) held.push_back(j->id);
    for (const std::string& id : held) {
      const Job& j = *m_jobs.find(id);
      Runtime& rt = m_runtime[id];
      if (running.count(id)) {
        rt.attached = true;
        rt.missingSince.reset();
        if (j.state == JobState::kStarting) {
          Job next = j;
          (void)JobTable::transition(next, JobState::kRunning, "", now);
          (void)commitLocked(next, "running (its agent on " + hb.node + " lists it)");
        }
      } else if (rt.attached && !rt.missingSince) {
        rt.missingSince = now;
      }
    }
    checkNodesLocked(actions);
    scheduleLocked(actions);
  }
  runActions(std::move(actions));
  return reply;
}

Result<bool> Manager::reportProgress(const std::string& jobId, const Progress& p, const std::string& message, int attempt) {
  ErrorList errors;
  if (Status bad = checkJobIdField(jobId); !bad) errors.add("job_id", bad.message());
  if (p.step < 0) errors.add("progress.step", "is negative (" + std::to_string(p.step) + ")");
  if (p.totalSteps < 0) errors.add("progress.total_steps", "is negative (" + std::to_string(p.totalSteps) + ")");
  if (!(p.time >= 0)) errors.add("progress.time", "is negative or not a number");
  if (!(p.duration >= 0)) errors.add("progress.duration", "is negative or not a number");
  if (!(p.particleStepsPerSecond >= 0)) errors.add("progress.particle_steps_per_second", "is negative or not a number");
  if (!(p.etaSeconds >= 0)) errors.add("progress.eta_seconds", "is negative or not a number");
  if (!errors.empty()) return errors.toStatus("ReportProgress");

  std::lock_guard lock(m_mu);
  const Job* j = m_jobs.find(jobId);
  if (!j) return notFound("no job '" + jobId + "'");
  if (isFinal(j->state)) return true;  // a stray worker of an ended job: tell it to stop
  if (usesSlurm() && isWaiting(j->state) && !j->slurmJobId.empty() && (attempt > 0 ? attempt : 1) == j->attempts + 1) {
    // Slurm started this attempt before the manager's poll saw it run: it starts now (its devices come with the poll).
    Job next = *j;
    if (next.state == JobState::kQueued) next.reason.clear();  // "waiting in Slurm ...": no longer
    (void)JobTable::transition(next, JobState::kStarting, "", m_clock.now());
    if (Status s = commitLocked(next, "starting: its worker reported before Slurm's state was read"); !s) return s;
    m_runtime[jobId].attached = true;
    j = m_jobs.find(jobId);
  }
  if (j->state == JobState::kRequeued) return true;  // a worker of the attempt that was given up: stop
  if (j->attempts > 0 && (attempt > 0 ? attempt : 1) != j->attempts) return true;  // a worker of an earlier attempt
  if (j->state == JobState::kQueued || j->state == JobState::kBuilding)
    return failedPrecondition("job " + jobId + " is queued: it has no worker that could report progress");

  const double now = m_clock.now();
  Job next = *j;
  Progress q = p;
  const double dt = now - j->progressAt;
  if (q.particleStepsPerSecond <= 0 && j->progressAt > 0 && dt > 0 && q.step > j->progress.step)
    q.particleStepsPerSecond = static_cast<double>(q.step - j->progress.step) * static_cast<double>(j->particles) / dt;
  if (q.etaSeconds <= 0) {
    if (q.totalSteps > q.step && q.particleStepsPerSecond > 0 && j->particles > 0) {
      q.etaSeconds = static_cast<double>(q.totalSteps - q.step) * static_cast<double>(j->particles) / q.particleStepsPerSecond;
    } else if (q.duration > q.time && j->progressAt > 0 && dt > 0 && q.time > j->progress.time) {
      q.etaSeconds = (q.duration - q.time) / ((q.time - j->progress.time) / dt);
    }
  }
  next.progress = q;
  next.progressAt = now;
  if (!message.empty()) next.message = message;
  const bool started = next.state == JobState::kStarting;
  if (started) (void)JobTable::transition(next, JobState::kRunning, "", now);
  Runtime* rt = nullptr;
  if (auto it = m_runtime.find(jobId); it != m_runtime.end()) {
    rt = &it->second;
    rt->attached = true;
  }
  // Progress arrives every second per job: watchers see each report, the store gets one at most every
  // kProgressSaveSeconds (a restart then resumes from a report a few seconds old) and every state change.
  const std::string event = message.empty() ? "progress" : message;
  if (started || !rt || now - rt->progressSavedAt >= kProgressSaveSeconds) {
    if (Status s = commitLocked(next, event); !s) return s;
    if (auto it = m_runtime.find(jobId); it != m_runtime.end()) it->second.progressSavedAt = now;
  } else {
    publishLocked(next, event);
  }
  return next.state == JobState::kCancelling;
}

Status Manager::reportExit(const std::string& jobId, const std::string& node, int exitCode, const std::string& reason) {
  if (Status bad = checkJobIdField(jobId); !bad) return invalidArgument("ReportJobExit: " + bad.message());
  if (node.empty()) return invalidArgument("ReportJobExit: node is empty (the node whose worker exited)");
  Actions actions;
  {
    std::lock_guard lock(m_mu);
    const Job* j = m_jobs.find(jobId);
    if (!j) return notFound("no job '" + jobId + "'");
    if (isFinal(j->state)) return Status::ok();  // it already ended (e.g. its node was declared lost)
    if (j->state == JobState::kRequeued) return Status::ok();  // the exit of an attempt already given up
    if (j->state == JobState::kQueued || j->state == JobState::kBuilding)
      return failedPrecondition("job " + jobId + " is " + jobStateName(j->state) + ": it has no worker that could exit");
    const auto nodes = nodesOf(*j);
    if (!nodes.count(node))
      return failedPrecondition("job " + jobId + " does not run on node '" + node + "' (it runs on " + describeDevices(j->devices) + ")");
    const std::string code = "exit code " + std::to_string(exitCode);
    if (j->state == JobState::kCancelling) {
      endLocked(*j, JobState::kCancelled, "", exitCode, "cancelled: the worker stopped (" + code + ")");
    } else if (exitCode == 0) {
      endLocked(*j, JobState::kSucceeded, "", exitCode, "succeeded");
    } else {
      const std::string why = "the worker failed with " + code + (reason.empty() ? "" : ": " + reason);
      // Killed from outside, or cut off from a service or its disk: another attempt (elsewhere) may succeed. A
      // simulation's own error (exit code 3, a crash) would repeat.
      const bool external = exitCode == 2 || exitCode == 128 + SIGKILL || exitCode == 128 + SIGTERM || exitCode == 128 + SIGHUP ||
                            exitCode == 128 + SIGINT;
      if (external)
        requeueOrFailLocked(*j, why, exitCode);
      else
        endLocked(*j, JobState::kFailed, why, exitCode, "failed: " + why);
    }
    scheduleLocked(actions);
  }
  runActions(std::move(actions));
  return Status::ok();
}

void Manager::checkNodesLocked(Actions& actions) {
  if (usesSlurm()) return;  // Slurm watches its nodes: a lost node ends the job NODE_FAIL (pollSlurm)
  const double now = m_clock.now();
  std::vector<std::string> forgotten;
  for (const std::string& node : m_inventory.expireLost(&forgotten))
    spdlog::warn("manager: node {} lost: no heartbeat for more than {}", node, seconds(m_options.heartbeatTimeoutSeconds));
  for (const std::string& node : forgotten)
    spdlog::info("manager: node {} forgotten: lost for more than {} (it returns with its next heartbeat)", node,
                 seconds(m_options.forgetLostNodeSeconds));

  std::vector<std::string> held;
  for (const Job* j : m_jobs.holdingDevices()) held.push_back(j->id);
  for (const std::string& id : held) {
    const Job& j = *m_jobs.find(id);
    std::string why;
    bool leadAlive = true;
    for (const std::string& node : nodesOf(j)) {
      if (m_inventory.isLost(node)) {
        why = "node " + node + " lost: no heartbeat for more than " + seconds(m_options.heartbeatTimeoutSeconds);
        if (node == leadNode(j)) leadAlive = false;
        break;
      }
      if (!m_inventory.isKnown(node) && now - m_loadedAt > m_options.heartbeatTimeoutSeconds) {
        why = "node " + node + " did not come back within " + seconds(m_options.heartbeatTimeoutSeconds) + " of the manager's restart";
        if (node == leadNode(j)) leadAlive = false;
        break;
      }
    }
    if (why.empty()) {
      const Runtime& rt = m_runtime[id];
      if (rt.missingSince && now - *rt.missingSince >= m_options.missingJobGraceSeconds)
        why = "the agent on node " + leadNode(j) + " no longer runs the worker (missing from its heartbeats for " +
              seconds(now - *rt.missingSince) + ")";
    }
    if (why.empty()) continue;
    if (leadAlive) stopAction(j, actions);
    if (j.state == JobState::kCancelling)
      endLocked(j, JobState::kCancelled, "", std::nullopt, "cancelled: " + why);
    else
      requeueOrFailLocked(j, why, std::nullopt);
  }
}

void Manager::tick() {
  if (usesSlurm()) pollSlurm();
  Actions actions;
  {
    std::lock_guard lock(m_mu);
    checkNodesLocked(actions);
    scheduleLocked(actions);
  }
  runActions(std::move(actions));
}

void Manager::setManagerAddress(const std::string& address) {
  std::lock_guard lock(m_mu);
  m_options.managerAddress = address;
}

std::vector<NodeView> Manager::nodes() const {
  std::lock_guard lock(m_mu);
  if (usesSlurm()) return m_slurmNodes;
  return m_inventory.snapshot();
}

}  // namespace pflow::manager
