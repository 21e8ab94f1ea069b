// The node agent's domain: its devices, the jobs it runs, heartbeats to the manager and exit reports. No gRPC:
// the manager is reached through RegistryClient (GrpcRegistryClient in the service library, fakes in tests).
#pragma once
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/Status.h"
#include "manager/agent/Devices.h"
#include "manager/agent/Supervisor.h"

namespace pflow::agent {

struct HeartbeatPayload {
  std::string node;
  std::string agentAddress;
  std::vector<DeviceInfo> devices;
  std::vector<std::string> runningJobs;
};

struct HeartbeatReply {
  double intervalSeconds = 0;  // 0: keep the current interval
  std::vector<std::string> stopJobs;
};

struct JobExitReport {
  std::string jobId;
  std::string node;
  int exitCode = 0;
  std::string reason;
};

// The manager's NodeRegistry as the agent uses it. Each call is one attempt with a deadline.
class RegistryClient {
 public:
  virtual ~RegistryClient() = default;
  virtual Result<HeartbeatReply> heartbeat(const HeartbeatPayload& payload) = 0;
  virtual Status reportJobExit(const JobExitReport& report) = 0;
};

struct AgentOptions {
  std::string node;                     // this node's name (as in DeviceRef.node)
  std::string advertiseAddress;         // host:port the manager calls back
  double heartbeatIntervalSeconds = 2;  // until the manager says otherwise
  double retryInitialSeconds = 0.5;     // exit-report retries: doubling up to retryMaxSeconds
  double retryMaxSeconds = 10;
  LaunchConfig launch;
};

// A device and the job that uses it here ("" when free).
struct DeviceStatus {
  DeviceInfo info;
  std::string jobId;
};

class Agent {
 public:
  // `registry` may be null: the agent then runs standalone (no heartbeats, exits only logged). Workers left running by
  // an earlier run of the agent (pid files in the workdir) are stopped and their exits reported (stopOrphans).
  Agent(AgentOptions options, std::unique_ptr<DeviceProbe> probe, std::shared_ptr<RegistryClient> registry);
  ~Agent();  // shutdown(5)
  Agent(const Agent&) = delete;
  Agent& operator=(const Agent&) = delete;

  const std::string& node() const { return m_options.node; }
  const AgentOptions& options() const { return m_options; }
  // The address heartbeats advertise, once the server has bound its port (call before startHeartbeats).
  void setAdvertiseAddress(const std::string& address);

  std::vector<DeviceStatus> devices();

  // Validates the lease (INVALID_ARGUMENT with every problem: job id, model, devices not of this node and not in
  // node_hosts, duplicates, unknown local devices, mixed kinds; FAILED_PRECONDITION when a local device is busy with
  // another job or the worker program is missing; ALREADY_EXISTS when the job runs) and starts its worker. Returns
  // the pid of mpirun (or of the worker when launched directly).
  Result<int> startJob(const Lease& lease);
  // NOT_FOUND when the job does not run here; else stops it (Supervisor::stop) and returns at once.
  Status stopJob(const std::string& jobId);
  std::vector<std::string> runningJobs() const;

  HeartbeatPayload heartbeatPayload();
  void handleHeartbeatReply(const HeartbeatReply& reply);  // adopts the interval, stops the jobs in stop_jobs
  Status heartbeatOnce();                                   // payload -> registry -> handleHeartbeatReply
  double heartbeatInterval() const;

  // Starts the heartbeat thread (a no-op without a registry).
  void startHeartbeats();
  // Stops heartbeats, stops every worker (SIGTERM, SIGKILL after the grace period) and tries to deliver the pending
  // exit reports for up to `flushSeconds`. Idempotent.
  void shutdown(double flushSeconds);

  std::size_t pendingExitReports() const;
  // Waits until no exit report is pending (tests); false on timeout.
  bool waitForReports(double seconds);

 private:
  void onWorkerExit(const WorkerExit& exit);
  void reporterLoop();
  void heartbeatLoop();
  ErrorList validate(const Lease& lease, const std::vector<DeviceInfo>& local) const;

  AgentOptions m_options;
  std::shared_ptr<RegistryClient> m_registry;

  std::mutex m_probeMutex;
  std::unique_ptr<DeviceProbe> m_probe;

  mutable std::mutex m_mutex;            // jobs, interval, flags
  std::map<std::string, Lease> m_jobs;   // running jobs
  std::vector<WorkerExit> m_orphans;     // workers of an earlier run of the agent, stopped; reported after a heartbeat
  double m_interval;
  bool m_quit = false;
  bool m_shutDown = false;
  std::condition_variable m_heartbeatCv;
  std::thread m_heartbeat;

  mutable std::mutex m_reportMutex;
  std::condition_variable m_reportCv;
  std::deque<JobExitReport> m_reports;
  bool m_reporterQuit = false;
  std::thread m_reporter;

  // Last: destroyed first, so its reaper never calls back into a half-destroyed agent.
  std::unique_ptr<Supervisor> m_supervisor;
};

// True for errors that mean "the manager did not answer" (worth retrying): UNAVAILABLE, DEADLINE_EXCEEDED,
// CANCELLED, RESOURCE_EXHAUSTED.
bool isTransient(const Status& s);

// Job ids become file names: 1-128 characters of [A-Za-z0-9._-], not starting with '.' or '-'.
bool isValidJobId(const std::string& id);

}  // namespace pflow::agent
