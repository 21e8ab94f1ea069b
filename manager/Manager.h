// The manager's domain: jobs, devices, placement, persistence, and the calls to agents and the frontend. No gRPC:
// ManagerService.cc adapts it to the wire. Thread-safe: one mutex guards the state; calls to agents and the
// frontend are made without holding it (they may block up to their deadlines).
//
// Errors (Status codes the adapters pass on):
//   INVALID_ARGUMENT    a malformed request or an invalid scene (the message lists what is wrong)
//   NOT_FOUND           an unknown job id
//   FAILED_PRECONDITION an operation the job's state does not allow (cancel a finished job, progress for a queued
//                       one); a job that can never fit on the devices that exist
//   RESOURCE_EXHAUSTED  too few devices free now and the submitter did not ask to wait
//   UNAVAILABLE         the frontend cannot be reached
//   IO                  the job database failed (nothing changed)
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/Clock.h"
#include "common/Status.h"
#include "manager/AgentClient.h"
#include "manager/FrontendClient.h"
#include "manager/Inventory.h"
#include "manager/JobDataClient.h"
#include "manager/JobStore.h"
#include "manager/JobTable.h"
#include "manager/Placement.h"
#include "manager/Types.h"
#include "manager/slurm/SlurmClient.h"
#include "manager/slurm/SlurmPlacement.h"

namespace pflow::manager {

struct ManagerOptions {
  PlacementThresholds thresholds;
  double heartbeatTimeoutSeconds = 15;   // a node silent this long is lost
  double heartbeatIntervalSeconds = 2;   // what agents are told to use
  double missingJobGraceSeconds = 15;    // a started job its agent's heartbeats stop listing fails after this long
  double forgetLostNodeSeconds = 600;    // a node lost this much longer leaves `pflow nodes` (back at its next heartbeat)
  // Starts a job may have: when its node is lost, its agent stops listing its worker, or the worker is killed by a
  // signal or cannot reach a service (exit code 2), the job is REQUEUED until this many have failed, then FAILED.
  int maxAttempts = 3;
  std::string managerAddress;            // put in leases: where workers report progress
  std::string backendAddress;            // put in leases: where workers send snapshots
  // Placement through Slurm (pflow-manager --placement slurm): Slurm owns the nodes and the queue; the manager
  // submits each attempt with sbatch, follows it through scontrol and cancels it with scancel (ManagerSlurm.cc).
  // Unset: the agents place jobs.
  std::optional<slurm::SlurmSettings> slurm;
};

class Manager {
 public:
  using EventCallback = std::function<void(const JobEvent&)>;

  // Loads every job and lease from `store`. Jobs that were starting, running or cancelling stay so and re-attach
  // when their agents heartbeat (see heartbeat() and tick()).
  // With options.slurm, `slurm` is the client to Slurm (required) and `agents` is never called.
  static Result<std::unique_ptr<Manager>> create(ManagerOptions options, const Clock& clock, JobStore& store,
                                                 AgentClient& agents, FrontendClient& frontend,
                                                 slurm::SlurmClient* slurm = nullptr);

  // Builds the scene through the frontend, stores the job QUEUED and schedules it (it may come back STARTING or
  // RUNNING). Refused (nothing stored): RESOURCE_EXHAUSTED when too few devices are free and !wait (or other jobs
  // queue ahead of it); FAILED_PRECONDITION when it could never fit.
  Result<Job> submit(const SubmitRequest& request);
  // The same in two halves, so that SubmitJob answers at once (ManagerService): beginSubmit checks the request and
  // stores the job BUILDING; buildSubmitted (on a build thread) builds it and makes it QUEUED (and schedules it), or
  // FAILED with the scene's errors or "refused: <why>". A job cancelled while building stays CANCELLED.
  Result<Job> beginSubmit(const SubmitRequest& request);
  void buildSubmitted(const std::string& id, const SubmitRequest& request);
  Result<Job> get(const std::string& id) const;
  std::vector<Job> list(bool activeOnly) const;

  // The same as `who` may see and do them (docs/security.md): a user its own jobs, an admin every job; another
  // user's job is PERMISSION_DENIED (which says no more than that).
  Result<Job> get(const Principal& who, const std::string& id) const;
  std::vector<Job> list(const Principal& who, bool activeOnly) const;
  Result<Job> cancel(const Principal& who, const std::string& id);
  Result<std::uint64_t> watch(const Principal& who, const std::string& id, EventCallback callback);
  // Deletes a finished job (`pflow delete`): its data on the back-end first (JobDataClient), then its record. Its
  // owner or an admin; FAILED_PRECONDITION for a job that has not ended (cancel it first). When the back-end cannot
  // delete, nothing is deleted. Its id is never given again.
  Status remove(const Principal& who, const std::string& id);
  // Where remove() deletes a job's data (main: the back-end; tests: a fake). Without one the record alone goes.
  void setJobDataClient(JobDataClient* client) { m_jobData = client; }
  // PERMISSION_DENIED unless job `jobId` holds a device on `node` (a node's worker reporting for it).
  Status checkJobOnNode(const std::string& jobId, const std::string& node) const;
  // QUEUED -> CANCELLED; STARTING/RUNNING -> CANCELLING (the agent is asked to stop the worker). Cancelling a
  // cancelling or cancelled job again returns it unchanged; a succeeded or failed one is FAILED_PRECONDITION.
  Result<Job> cancel(const std::string& id);

  // Calls `callback` with the job now, then with every change (state, progress), until the job is final. The
  // callback runs under the manager's lock: it must be quick and must not call back into the Manager. Returns a
  // subscription id for unwatch(); after unwatch() returns, the callback is never called again.
  Result<std::uint64_t> watch(const std::string& id, EventCallback callback);
  void unwatch(std::uint64_t subscription);

  Result<HeartbeatReply> heartbeat(const HeartbeatInfo& hb);
  // Records progress (STARTING -> RUNNING on the first report) and fills in the rate and ETA when the worker
  // left them 0. Returns whether the worker should stop (the job is cancelling, or already ended).
  // `attempt`: the reporting worker's (0 = 1); a worker of an earlier attempt is answered "stop" and not recorded.
  Result<bool> reportProgress(const std::string& jobId, const Progress& progress, const std::string& message, int attempt = 0);
  // Exit code 0 -> SUCCEEDED; a cancelling job -> CANCELLED; a worker killed by SIGKILL/SIGTERM/SIGHUP/SIGINT or
  // exiting with 2 (a service out of reach, an I/O error) -> REQUEUED while attempts are left; otherwise FAILED with
  // the reason. Frees the devices.
  // A report for a job that already ended is accepted and ignored.
  Status reportExit(const std::string& jobId, const std::string& node, int exitCode, const std::string& reason);

  // Lost-node detection, jobs whose agents stopped listing them, re-attachment deadlines after a restart, and the
  // queue. main() calls it from a timer thread; tests call it directly.
  void tick();

  std::vector<NodeView> nodes() const;
  double now() const { return m_clock.now(); }
  // The address leases carry for workers (main() sets it once the server's port is known when listening on :0).
  void setManagerAddress(const std::string& address);

 private:
  struct Action {
    enum class Kind { kStart, kStop, kSubmit } kind;
    std::string jobId;
    std::string address;       // agents: the agent's; Slurm: the Slurm job id to cancel
    Lease lease;
    slurm::Submission submission;  // kSubmit: sbatch's request and the script it runs
    std::string script;
  };
  static constexpr double kProgressSaveSeconds = 10;
  struct Runtime {
    bool attached = false;               // the agent confirmed the worker (start answer, progress, heartbeat)
    std::optional<double> missingSince;  // first heartbeat of its agent that did not list it
    double progressSavedAt = 0;          // when its progress last went to the store
  };
  struct Watcher {
    std::string jobId;
    EventCallback callback;
  };
  using Actions = std::vector<Action>;

  Manager(ManagerOptions options, const Clock& clock, JobStore& store, AgentClient& agents, FrontendClient& frontend);

  // Stores `next`, updates leases, then publishes it.
  Status commitLocked(Job next, const std::string& event);
  // The job table and the watchers only (no store, no leases): for progress between saves.
  void publishLocked(const Job& next, const std::string& event);
  // The transition to `to` (a final state, or REQUEUED), stored and published.
  void endLocked(const Job& job, JobState to, const std::string& reason, std::optional<int> exitCode, const std::string& event);
  // A failure a new attempt may not repeat: REQUEUED while the job has attempts left, else FAILED ("attempt N of M").
  void requeueOrFailLocked(const Job& job, const std::string& why, std::optional<int> exitCode);
  void scheduleLocked(Actions& actions);
  void checkNodesLocked(Actions& actions);
  Lease leaseFor(const Job& job) const;
  void stopAction(const Job& job, Actions& actions) const;
  Status checkAccess(const Principal& who, const std::string& id) const;
  // Placement of `request` now: agents over the inventory; Slurm whether it could ever fit on Slurm's nodes.
  Placement placeLocked(const PlacementRequest& request) const;
  // Fields of a submission and a cheap never-fits check (before an expensive build).
  Status checkSubmit(const SubmitRequest& req) const;
  // A job from a submission (no seq, id or state yet).
  Job jobFor(const SubmitRequest& req) const;
  // Takes the built model into `j` when the job may be queued: its particles, memory, steps; else the refusal
  // (FAILED_PRECONDITION never fits, RESOURCE_EXHAUSTED too few free devices without wait) or the build's error.
  Status admitLocked(Job& j, const Result<BuiltModel>& model, std::string& event) const;
  void runActions(Actions actions);
  void applyStart(const Action& a, const Result<std::int64_t>& result, Actions& more);
  void applyStop(const Action& a, const Status& result, Actions& more);
  // Placement through Slurm (ManagerSlurm.cc).
  bool usesSlurm() const { return m_slurm != nullptr; }
  void scheduleSlurmLocked(Actions& actions);
  void applySubmit(const Action& a, const Result<std::string>& result, Actions& more);
  Result<std::string> submitToSlurm(const Action& a);
  void pollSlurm();  // jobs and nodes from slurmctld (outside the lock), then applySlurmLocked
  // `began`: when the read of Slurm started (a job recorded later may be missing from it).
  void applySlurmLocked(const std::vector<slurm::JobInfo>& jobs, const std::vector<slurm::NodeInfo>& nodes, double began,
                        Actions& actions);
  void applySlurmJobLocked(const Job& job, const slurm::JobInfo* info);
  // A waiting job whose Slurm job ran: STARTING on the devices Slurm gave it (so it may end as a started job does).
  Job startedFromSlurmLocked(const Job& job, const slurm::JobInfo& info);

  ManagerOptions m_options;
  const Clock& m_clock;
  JobStore& m_store;
  AgentClient& m_agents;
  FrontendClient& m_frontend;
  JobDataClient* m_jobData = nullptr;

  mutable std::mutex m_mu;
  Inventory m_inventory;
  JobTable m_jobs;
  std::map<std::string, Runtime> m_runtime;  // jobs holding devices
  std::map<std::uint64_t, Watcher> m_watchers;
  std::uint64_t m_nextWatcher = 1;
  double m_loadedAt = 0;

  slurm::SlurmClient* m_slurm = nullptr;
  std::vector<NodeView> m_slurmNodes;    // Slurm's nodes as last read (nodes(), placement)
  bool m_slurmNodesKnown = false;
  std::map<std::string, double> m_slurmRecordedAt;  // job -> when its current Slurm id was recorded (this run)
  std::map<std::string, int> m_slurmMissing;        // job -> reads of Slurm in a row without its Slurm job
  double m_slurmPolledAt = -1e300;
  std::set<std::string> m_submitting;    // jobs whose sbatch is in flight
  std::mutex m_pollMu;                   // one poll at a time
};

}  // namespace pflow::manager
