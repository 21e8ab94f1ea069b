#include "manager/agent/Agent.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <set>

#include "common/Log.h"

namespace pflow::agent {

bool isTransient(const Status& s) {
  switch (s.code()) {
    case StatusCode::kUnavailable:
    case StatusCode::kDeadlineExceeded:
    case StatusCode::kCancelled:
    case StatusCode::kResourceExhausted: return true;
    default: return false;
  }
}

bool isValidJobId(const std::string& id) {
  if (id.empty() || id.size() > 128 || id[0] == '.' || id[0] == '-') return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
  });
}

Agent::Agent(AgentOptions options, std::unique_ptr<DeviceProbe> probe, std::shared_ptr<RegistryClient> registry)
    : m_options(std::move(options)),
      m_registry(std::move(registry)),
      m_probe(std::move(probe)),
      m_interval(m_options.heartbeatIntervalSeconds) {
  if (m_registry) m_reporter = std::thread([this] { reporterLoop(); });
  m_supervisor = std::make_unique<Supervisor>([this](const WorkerExit& x) { onWorkerExit(x); },
                                              m_options.launch.graceSeconds);
  // Workers an earlier run of this agent started and that outlived it: stopped now, reported after the first
  // heartbeat (so the manager knows this agent's new address before it requeues and places their jobs again; they go
  // on from their checkpoints), so that none holds a device nobody accounts for.
  m_orphans = stopOrphans(m_options.launch.workdir, m_options.launch.graceSeconds);
}

Agent::~Agent() {
  shutdown(5);
  m_supervisor.reset();  // joins the reaper before the members it calls back into go
}

std::vector<DeviceStatus> Agent::devices() {
  std::vector<DeviceInfo> found;
  {
    std::lock_guard lock(m_probeMutex);
    found = m_probe->probe();
  }
  std::lock_guard lock(m_mutex);
  std::vector<DeviceStatus> out;
  for (DeviceInfo& d : found) {
    DeviceStatus s{std::move(d), ""};
    for (const auto& [id, lease] : m_jobs) {
      for (const DeviceRef& r : lease.devices) {
        if (r.node == m_options.node && r.kind == s.info.kind && r.index == s.info.index) s.jobId = id;
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

ErrorList Agent::validate(const Lease& lease, const std::vector<DeviceInfo>& local) const {
  ErrorList errors;
  if (!isValidJobId(lease.jobId)) {
    errors.add("lease.job_id", "'" + lease.jobId + "' is not a job id (1-128 of A-Z a-z 0-9 . _ -, not starting with . or -)");
  }
  if (lease.modelUri.empty()) errors.add("lease.model_uri", "empty");
  if (lease.devices.empty()) errors.add("lease.devices", "no device: a lease needs one device per rank");
  std::set<std::string> seen;
  for (std::size_t i = 0; i < lease.devices.size(); ++i) {
    const DeviceRef& d = lease.devices[i];
    const std::string path = "lease.devices[" + std::to_string(i) + "]";
    if (d.node.empty()) {
      errors.add(path + ".node", "empty");
      continue;
    }
    if (d.index < 0) errors.add(path + ".index", "negative (" + std::to_string(d.index) + ")");
    if (!seen.insert(d.toString()).second) errors.add(path, d.toString() + " is listed twice");
    if (d.kind != lease.devices.front().kind) {
      errors.add(path + ".kind", "a lease uses one device kind (" + std::string(deviceKindName(lease.devices.front().kind)) +
                                     " first, " + deviceKindName(d.kind) + " here)");
    }
    if (d.node == m_options.node) {
      const bool exists = std::any_of(local.begin(), local.end(),
                                      [&](const DeviceInfo& l) { return l.kind == d.kind && l.index == d.index; });
      if (!exists) errors.add(path, d.toString() + ": this node has no such device");
    } else if (!lease.nodeHosts.count(d.node)) {
      errors.add(path + ".node", "'" + d.node + "' is not this node (" + m_options.node + ") and has no entry in node_hosts");
    }
  }
  return errors;
}

Result<int> Agent::startJob(const Lease& lease) {
  std::vector<DeviceInfo> local;
  {
    std::lock_guard lock(m_probeMutex);
    local = m_probe->probe();
  }
  if (ErrorList errors = validate(lease, local); !errors.empty()) {
    Status s = errors.toStatus("lease for job '" + lease.jobId + "'");
    spdlog::warn("refused: {}", s.message());
    return s;
  }
  const std::string& worker = m_options.launch.workerPath;
  if (worker.find('/') != std::string::npos && ::access(worker.c_str(), X_OK) != 0) {
    return failedPrecondition("the worker program " + worker + " is missing or not executable (--worker)");
  }

  std::lock_guard lock(m_mutex);
  if (m_shutDown) return unavailable("the agent is shutting down");
  if (m_jobs.count(lease.jobId) || m_supervisor->isRunning(lease.jobId)) {
    return alreadyExists("job " + lease.jobId + " already runs on node " + m_options.node);
  }
  for (const DeviceRef& d : lease.devices) {
    if (d.node != m_options.node) continue;
    for (const auto& [id, other] : m_jobs) {
      if (std::find(other.devices.begin(), other.devices.end(), d) != other.devices.end()) {
        return failedPrecondition("device " + d.toString() + " is busy with job " + id);
      }
    }
  }
  const LaunchPlan plan = planLaunch(lease, m_options.launch, m_options.node);
  if (plan.rankDevices != lease.devices) {
    spdlog::warn("job {}: devices regrouped by host for mpirun; rank order is now {}", lease.jobId,
                 workerCommand(lease, plan.rankDevices, "").back());
  }
  Result<int> pid = m_supervisor->start(plan);
  if (pid) m_jobs.emplace(lease.jobId, lease);
  return pid;
}

Status Agent::stopJob(const std::string& jobId) {
  if (!m_supervisor->isRunning(jobId)) return notFound("job " + jobId + " does not run on node " + m_options.node);
  return m_supervisor->stop(jobId);
}

void Agent::setAdvertiseAddress(const std::string& address) {
  std::lock_guard lock(m_mutex);
  m_options.advertiseAddress = address;
}

std::vector<std::string> Agent::runningJobs() const { return m_supervisor->running(); }

HeartbeatPayload Agent::heartbeatPayload() {
  HeartbeatPayload p;
  p.node = m_options.node;
  {
    std::lock_guard lock(m_mutex);
    p.agentAddress = m_options.advertiseAddress;
  }
  for (DeviceStatus& d : devices()) p.devices.push_back(std::move(d.info));
  p.runningJobs = runningJobs();
  return p;
}

void Agent::handleHeartbeatReply(const HeartbeatReply& reply) {
  if (reply.intervalSeconds > 0) {
    std::lock_guard lock(m_mutex);
    if (reply.intervalSeconds != m_interval) spdlog::info("heartbeat interval {} s (manager)", reply.intervalSeconds);
    m_interval = reply.intervalSeconds;
  }
  for (const std::string& id : reply.stopJobs) {
    if (!m_supervisor->isRunning(id)) continue;  // already gone: its exit is (being) reported
    spdlog::info("job {}: the manager asks to stop it", id);
    (void)m_supervisor->stop(id);
  }
}

Status Agent::heartbeatOnce() {
  if (!m_registry) return failedPrecondition("no manager configured");
  Result<HeartbeatReply> reply = m_registry->heartbeat(heartbeatPayload());
  if (!reply) return reply.status();
  handleHeartbeatReply(reply.value());
  std::vector<WorkerExit> orphans;
  {
    std::lock_guard lock(m_mutex);
    orphans.swap(m_orphans);
  }
  for (const WorkerExit& x : orphans) onWorkerExit(x);
  return Status::ok();
}

double Agent::heartbeatInterval() const {
  std::lock_guard lock(m_mutex);
  return m_interval;
}

void Agent::startHeartbeats() {
  if (!m_registry) return;
  std::lock_guard lock(m_mutex);
  if (m_heartbeat.joinable() || m_shutDown) return;
  m_heartbeat = std::thread([this] { heartbeatLoop(); });
}

void Agent::heartbeatLoop() {
  bool failing = false;
  while (true) {
    const Status s = heartbeatOnce();
    if (!s.isOk() && !failing) spdlog::warn("heartbeat failed: {} (retrying every interval)", s.toString());
    if (s.isOk() && failing) spdlog::info("heartbeats reach the manager again");
    failing = !s.isOk();
    std::unique_lock lock(m_mutex);
    if (m_heartbeatCv.wait_for(lock, std::chrono::duration<double>(m_interval), [this] { return m_quit; })) return;
  }
}

void Agent::onWorkerExit(const WorkerExit& exit) {
  {
    std::lock_guard lock(m_mutex);
    m_jobs.erase(exit.jobId);
  }
  if (!m_registry) return;
  {
    std::lock_guard lock(m_reportMutex);
    m_reports.push_back({exit.jobId, m_options.node, exit.exitCode, exit.reason});
  }
  m_reportCv.notify_all();
}

void Agent::reporterLoop() {
  double backoff = m_options.retryInitialSeconds;
  int failures = 0;
  std::unique_lock lock(m_reportMutex);
  while (true) {
    m_reportCv.wait(lock, [this] { return m_reporterQuit || !m_reports.empty(); });
    if (m_reports.empty()) return;  // quit with nothing pending
    const JobExitReport report = m_reports.front();
    lock.unlock();
    const Status s = m_registry->reportJobExit(report);
    lock.lock();
    if (s.isOk() || !isTransient(s)) {
      if (!s.isOk()) spdlog::error("job {}: the manager refused its exit report: {}", report.jobId, s.toString());
      else spdlog::info("job {}: exit (code {}) reported to the manager", report.jobId, report.exitCode);
      m_reports.pop_front();
      backoff = m_options.retryInitialSeconds;
      failures = 0;
      m_reportCv.notify_all();
      continue;
    }
    if (failures++ == 0) spdlog::warn("job {}: exit report not delivered ({}); retrying", report.jobId, s.toString());
    if (m_reportCv.wait_for(lock, std::chrono::duration<double>(backoff), [this] { return m_reporterQuit; })) {
      for (const JobExitReport& r : m_reports) {
        spdlog::error("job {}: exit (code {}, {}) never reached the manager", r.jobId, r.exitCode, r.reason);
      }
      return;
    }
    backoff = std::min(backoff * 2, m_options.retryMaxSeconds);
  }
}

std::size_t Agent::pendingExitReports() const {
  std::lock_guard lock(m_reportMutex);
  return m_reports.size();
}

bool Agent::waitForReports(double seconds) {
  std::unique_lock lock(m_reportMutex);
  return m_reportCv.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return m_reports.empty(); });
}

void Agent::shutdown(double flushSeconds) {
  {
    std::lock_guard lock(m_mutex);
    if (m_shutDown) return;
    m_shutDown = true;
    m_quit = true;
  }
  m_heartbeatCv.notify_all();
  if (m_heartbeat.joinable()) m_heartbeat.join();
  const auto jobs = m_supervisor->running();
  if (!jobs.empty()) {
    spdlog::info("stopping {} worker(s)", jobs.size());
    if (!m_supervisor->stopAll(m_options.launch.graceSeconds + 5)) spdlog::error("some workers outlived SIGKILL");
  }
  if (m_reporter.joinable()) {
    waitForReports(flushSeconds);
    {
      std::lock_guard lock(m_reportMutex);
      m_reporterQuit = true;
    }
    m_reportCv.notify_all();
    m_reporter.join();
  }
}

}  // namespace pflow::agent
