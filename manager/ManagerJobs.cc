// The Manager's jobs as users see them: submissions (checked, built, admitted), who may see, cancel, watch and
// delete what (docs/security.md). State changes, agents and nodes are in Manager.cc.
#include <spdlog/spdlog.h>

#include "manager/Manager.h"
#include "manager/ManagerDetail.h"

namespace pflow::manager {

using namespace detail;

// ---- jobs --------------------------------------------------------------------------------------------------------

Status Manager::checkSubmit(const SubmitRequest& req) const {
  ErrorList errors;
  if (req.sceneYaml.empty()) errors.add("scene_yaml", "is empty: send the scene's YAML text");
  if (req.maxDevices < 0) errors.add("max_devices", "is negative (" + std::to_string(req.maxDevices) + "); 0 means no limit");
  for (const auto& [field, value] : {std::pair{"name", &req.name}, {"scene_name", &req.sceneName}}) {
    if (value->size() > 256) errors.add(field, "is " + std::to_string(value->size()) + " bytes; the limit is 256");
    else if (!log::isPrintable(*value)) errors.add(field, "'" + log::escaped(*value) + "' has characters other than printable ASCII");
  }
  if (req.files.size() > 1000) errors.add("files", std::to_string(req.files.size()) + " files; the limit is 1000");
  std::set<std::string> paths;
  for (std::size_t i = 0; i < req.files.size() && i < 1000; ++i) {
    const std::string path = "files[" + std::to_string(i) + "].path";
    const std::string& p = req.files[i].path;
    if (p.empty()) errors.add(path, "is empty");
    else if (p.size() > 256 || !log::isPrintable(p)) errors.add(path, "'" + log::escaped(p) + "': at most 256 printable ASCII characters");
    else if (!paths.insert(p).second) errors.add(path, "repeats '" + p + "'");
  }
  if (!errors.empty()) return errors.toStatus("SubmitJob");

  {  // cheap refusal before an expensive build
    std::lock_guard lock(m_mu);
    const Placement p = placeLocked({1, 0, 0});
    if (p.outcome == PlacementOutcome::kNeverFits) return failedPrecondition("job refused: " + p.reason);
  }
  return Status::ok();
}

Placement Manager::placeLocked(const PlacementRequest& request) const {
  if (!usesSlurm()) return place(request, m_inventory.snapshot(), m_options.thresholds);
  // Slurm queues a job until its devices are free: only whether it could ever fit counts here, and before the first
  // read of Slurm's nodes not even that (scheduleSlurmLocked checks it again).
  Placement p;
  p.outcome = PlacementOutcome::kPlaced;
  if (!m_slurmNodesKnown) return p;
  p = place(request, slurm::everyDevice(m_slurmNodes, m_options.slurm->partition), m_options.thresholds);
  if (p.outcome == PlacementOutcome::kWait) p.outcome = PlacementOutcome::kPlaced;
  if (p.outcome == PlacementOutcome::kPlaced) p.reason.clear();
  return p;
}

Job Manager::jobFor(const SubmitRequest& req) const {
  Job j;
  j.name = req.name.empty() ? req.sceneName : req.name;
  j.sceneName = req.sceneName;
  j.maxDevices = req.maxDevices;
  j.maxAttempts = m_options.maxAttempts;
  j.owner = req.owner;
  j.wait = req.wait;
  j.submittedAt = m_clock.now();
  return j;
}

Status Manager::admitLocked(Job& j, const Result<BuiltModel>& model, std::string& event) const {
  if (!model) return model.status();
  if (model->particles == 0) return invalidArgument("scene '" + j.sceneName + "' has no particles: nothing to simulate");
  const Placement p = placeLocked({model->particles, model->memoryBytes, j.maxDevices});
  if (p.outcome == PlacementOutcome::kNeverFits) return failedPrecondition("job refused: " + p.reason);
  std::size_t ahead = 0;
  for (const Job* q : m_jobs.queued()) ahead += q->id != j.id;
  if (!j.wait && p.outcome == PlacementOutcome::kWait)
    return resourceExhausted("too few free devices: the job " + p.reason + " (submit with wait to queue it)");
  if (!j.wait && ahead > 0)
    return resourceExhausted("devices are promised to " + std::to_string(ahead) + " queued job(s) ahead of this one (submit with wait to queue it)");
  j.modelId = model->modelId;
  j.modelUri = model->modelUri;
  j.particles = model->particles;
  j.memoryBytes = model->memoryBytes;
  j.model = model->model;
  j.slurm = model->slurm;
  j.progress.totalSteps = model->steps;
  j.progress.duration = model->duration;
  event = p.outcome == PlacementOutcome::kWait ? "queued: the job " + p.reason : "queued";
  j.reason = p.outcome == PlacementOutcome::kWait ? "waiting: the job " + p.reason : "";
  return Status::ok();
}

Result<Job> Manager::submit(const SubmitRequest& req) {
  if (Status s = checkSubmit(req); !s) return s;
  const Result<BuiltModel> model = m_frontend.buildScene(req.sceneYaml, req.sceneName, req.files);
  Actions actions;
  std::string id;
  {
    std::lock_guard lock(m_mu);
    Job j = jobFor(req);
    std::string event;
    if (Status s = admitLocked(j, model, event); !s) return s;  // refused: nothing stored
    j.seq = m_jobs.maxSeq() + 1;
    j.id = jobIdFor(j.seq);
    j.state = JobState::kQueued;
    if (Status s = commitLocked(j, event); !s) return s;
    id = j.id;
    scheduleLocked(actions);
  }
  runActions(std::move(actions));
  return get(id);
}

Result<Job> Manager::beginSubmit(const SubmitRequest& req) {
  if (Status s = checkSubmit(req); !s) return s;
  std::lock_guard lock(m_mu);
  Job j = jobFor(req);
  j.seq = m_jobs.maxSeq() + 1;
  j.id = jobIdFor(j.seq);
  j.state = JobState::kBuilding;
  if (Status s = commitLocked(j, "building the scene"); !s) return s;
  return j;
}

void Manager::buildSubmitted(const std::string& id, const SubmitRequest& req) {
  {
    std::lock_guard lock(m_mu);
    const Job* j = m_jobs.find(id);
    if (!j || j->state != JobState::kBuilding) return;  // cancelled meanwhile
  }
  const Result<BuiltModel> model = m_frontend.buildScene(req.sceneYaml, req.sceneName, req.files);
  Actions actions;
  {
    std::lock_guard lock(m_mu);
    const Job* found = m_jobs.find(id);
    if (!found || found->state != JobState::kBuilding) return;  // cancelled while it was built
    Job j = *found;
    std::string event;
    if (Status s = admitLocked(j, model, event); !s) {
      // The scene's errors, or why it was refused ("refused: ..."; the CLI exits 5 on it, as on RESOURCE_EXHAUSTED).
      const bool refused = s.code() == StatusCode::kResourceExhausted || s.code() == StatusCode::kFailedPrecondition;
      const std::string why = (refused ? "refused: " : "") + s.message();
      endLocked(*found, JobState::kFailed, why, std::nullopt, "failed: " + why);
      return;
    }
    (void)JobTable::transition(j, JobState::kQueued, j.reason, m_clock.now());
    if (Status s = commitLocked(j, event); !s) return;
    scheduleLocked(actions);
  }
  runActions(std::move(actions));
}

Result<Job> Manager::get(const std::string& id) const {
  if (Status bad = checkJobIdField(id); !bad) return bad;
  std::lock_guard lock(m_mu);
  const Job* j = m_jobs.find(id);
  if (!j) return notFound("no job '" + id + "'");
  return *j;
}

std::vector<Job> Manager::list(bool activeOnly) const {
  std::lock_guard lock(m_mu);
  return m_jobs.list(activeOnly);
}

Status Manager::checkAccess(const Principal& who, const std::string& id) const {
  if (Status bad = checkJobIdField(id); !bad) return bad;
  std::lock_guard lock(m_mu);
  const Job* j = m_jobs.find(id);
  if (!j) return notFound("no job '" + id + "'");
  if (!who.mayAccess(*j)) return permissionDenied("job " + id + " is not yours");
  return Status::ok();
}

Result<Job> Manager::get(const Principal& who, const std::string& id) const {
  if (Status s = checkAccess(who, id); !s) return s;
  return get(id);
}

std::vector<Job> Manager::list(const Principal& who, bool activeOnly) const {
  std::vector<Job> all = list(activeOnly);
  std::erase_if(all, [&](const Job& j) { return !who.mayAccess(j); });
  return all;
}

Result<Job> Manager::cancel(const Principal& who, const std::string& id) {
  if (Status s = checkAccess(who, id); !s) return s;
  return cancel(id);
}

Result<std::uint64_t> Manager::watch(const Principal& who, const std::string& id, EventCallback callback) {
  if (Status s = checkAccess(who, id); !s) return s;
  return watch(id, std::move(callback));
}

Status Manager::remove(const Principal& who, const std::string& id) {
  if (Status s = checkAccess(who, id); !s) return s;
  {
    std::lock_guard lock(m_mu);
    const Job* j = m_jobs.find(id);
    if (!j) return notFound("no job '" + id + "'");
    if (!isFinal(j->state))
      return failedPrecondition("job " + id + " is " + jobStateName(j->state) + ": cancel it and delete it once it has ended");
  }
  // Outside the lock (a call with a deadline); the job is final, so nothing writes its data any more.
  if (m_jobData)
    if (Status s = m_jobData->deleteJobData(id); !s) return s;
  std::lock_guard lock(m_mu);
  if (!m_jobs.find(id)) return Status::ok();  // deleted meanwhile by another call
  if (Status s = m_store.remove(id); !s) return s;
  m_jobs.erase(id);
  spdlog::info("manager: job {} deleted by {}", id, who.name);
  return Status::ok();
}

Status Manager::checkJobOnNode(const std::string& jobId, const std::string& node) const {
  if (Status bad = checkJobIdField(jobId); !bad) return bad;
  std::lock_guard lock(m_mu);
  const Job* j = m_jobs.find(jobId);
  if (!j) return notFound("no job '" + jobId + "'");
  if (!nodesOf(*j).count(node)) return permissionDenied("job " + jobId + " holds no device on node " + node);
  return Status::ok();
}

Result<Job> Manager::cancel(const std::string& id) {
  if (Status bad = checkJobIdField(id); !bad) return bad;
  Actions actions;
  {
    std::lock_guard lock(m_mu);
    const Job* j = m_jobs.find(id);
    if (!j) return notFound("no job '" + id + "'");
    switch (j->state) {
      case JobState::kBuilding:
        endLocked(*j, JobState::kCancelled, "cancelled while its scene was built", std::nullopt, "cancelled while building");
        break;
      case JobState::kQueued:
      case JobState::kRequeued: {
        const Job queued = *j;
        endLocked(queued, JobState::kCancelled, "cancelled while queued", std::nullopt, "cancelled while queued");
        if (usesSlurm()) stopAction(queued, actions);  // scancel the pending Slurm job
        scheduleLocked(actions);      // the jobs behind it may fit now
        break;
      }
      case JobState::kStarting:
      case JobState::kRunning: {
        Job next = *j;
        (void)JobTable::transition(next, JobState::kCancelling, "cancelled by request", m_clock.now());
        if (Status s = commitLocked(next, "cancelling: asking the agent to stop the worker"); !s) return s;
        stopAction(next, actions);
        break;
      }
      case JobState::kCancelling:
        stopAction(*j, actions);  // ask again; the state stays
        break;
      case JobState::kCancelled:
        return *j;
      case JobState::kSucceeded:
      case JobState::kFailed:
        return failedPrecondition("job " + id + " already " + jobStateName(j->state) + "; there is nothing to cancel");
    }
  }
  runActions(std::move(actions));
  return get(id);
}

Result<std::uint64_t> Manager::watch(const std::string& id, EventCallback callback) {
  if (Status bad = checkJobIdField(id); !bad) return bad;
  std::lock_guard lock(m_mu);
  const Job* j = m_jobs.find(id);
  if (!j) return notFound("no job '" + id + "'");
  const std::uint64_t sub = m_nextWatcher++;
  callback(JobEvent{*j, std::string("now ") + jobStateName(j->state)});
  if (!isFinal(j->state)) m_watchers.emplace(sub, Watcher{id, std::move(callback)});
  return sub;
}

void Manager::unwatch(std::uint64_t subscription) {
  std::lock_guard lock(m_mu);
  m_watchers.erase(subscription);
}

}  // namespace pflow::manager
