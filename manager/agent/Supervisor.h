// Starts and watches compute workers: the mpirun command line for a lease, one process session per job, stop with
// SIGTERM then SIGKILL, and a reaper thread that reports every exit. No gRPC here.
#pragma once
#include <chrono>
#include <condition_variable>
#include <functional>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common/LogTail.h"
#include "common/Status.h"
#include "manager/agent/Devices.h"

namespace pflow::agent {

// A device of a lease: node, kind, index. Written "node:kind:index" on the worker's command line.
struct DeviceRef {
  std::string node;
  DeviceKind kind = DeviceKind::kGpu;
  int index = 0;
  std::string toString() const;  // "node-a:gpu:0"
  bool operator==(const DeviceRef&) const = default;
};

// What a job may use (the domain twin of pflow.agent.v1.Lease): one rank per device, in rank order.
struct Lease {
  std::string jobId;
  std::string modelUri;
  std::vector<DeviceRef> devices;
  std::map<std::string, std::string> nodeHosts;  // node -> host for the hostfile
  std::string managerAddress;
  std::string backendAddress;
  int attempt = 1;  // > 1: the manager requeued the job; the worker resumes from its last checkpoint (--resume)
};

// How the agent launches workers.
struct LaunchConfig {
  std::string workdir = "/tmp/pflow-agent";  // <job>.log and <job>.hosts go here
  std::string workerPath = "pflow-worker";
  std::vector<std::string> transportArgs;     // the agent's --tls-dir DIR or --insecure, passed on to its workers
  std::string mpirun = "mpirun";             // empty: run the worker command directly, no MPI (tests, debugging)
  std::vector<std::string> launcherPrefix;   // put in front of the whole command (e.g. a wrapper)
  std::string rshAgent;                      // --mca plm_rsh_agent (one-machine rehearsal); empty: Open MPI's ssh
  std::vector<std::string> passEnv = {"PATH", "LD_LIBRARY_PATH", "OMP_NUM_THREADS"};  // -x NAME for each one set
  std::vector<std::string> extraMpirunArgs;  // before the worker (e.g. {"--mca", "btl_tcp_if_include", "eth0"})
  double graceSeconds = 10;                  // SIGTERM .. SIGKILL
};

// The command for one lease: pure data, built by planLaunch, carried out by Supervisor::start.
struct LaunchPlan {
  std::string jobId;
  std::vector<std::string> argv;
  std::vector<std::pair<std::string, std::string>> env;  // set on top of the agent's own environment
  std::string logPath;                                    // <workdir>/<job>.log (stdout and stderr, appended)
  std::string hostfilePath;                               // "" on a single-node lease
  std::string hostfileText;
  std::vector<DeviceRef> rankDevices;                     // the device of rank r (the worker's --devices order)
};

// The worker's own arguments: WORKER --job-id ID --model URI [--manager ADDR] [--backend ADDR] --devices D0,D1,...
std::vector<std::string> workerCommand(const Lease& lease, const std::vector<DeviceRef>& rankDevices,
                                       const std::string& workerPath);

// The whole launch for `lease` on node `localNode`. A lease with a device on another node gets a hostfile (one line
// per host with slots = its device count, hosts in order of first appearance) and its ranks are grouped by host in
// that order (mpirun --map-by slot fills hosts in hostfile order), so rank r always runs on the host of the r-th
// device of --devices.
LaunchPlan planLaunch(const Lease& lease, const LaunchConfig& config, const std::string& localNode);

using pflow::lastErrorLine;  // common/LogTail.h

// How a worker ended.
struct WorkerExit {
  std::string jobId;
  int pid = 0;
  int exitCode = 0;      // the exit status, or 128 + signal number
  int signal = 0;        // the signal that ended it, 0 if it exited
  bool stopRequested = false;  // stop() was called
  bool killed = false;         // it outlived the grace period and got SIGKILL
  double seconds = 0;          // how long it ran
  std::string reason;          // "" after a clean exit; else the signal and/or the log's last error line
};

class Supervisor {
 public:
  using ExitCallback = std::function<void(const WorkerExit&)>;

  // `onExit` runs on the reaper thread once per worker; it must not block for long or call back into stop().
  explicit Supervisor(ExitCallback onExit, double graceSeconds = 10);
  ~Supervisor();  // stops every worker (as stopAll) and joins the reaper
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Writes the hostfile, starts the command in a new session (its own process group), stdout and stderr appended
  // to the log. ALREADY_EXISTS if the job runs; IO when the workdir, log or hostfile cannot be written; a failed exec
  // (no such program) is an error here, not an exit later. Returns the pid.
  Result<int> start(const LaunchPlan& plan);

  // SIGTERM to the worker's process group (mpirun forwards it to every rank); SIGKILL to every process of its
  // session once the grace period has passed. Returns at once; the exit arrives through the callback.
  // NOT_FOUND if the job does not run. Calling it again for a stopping job is harmless, also once the job was
  // reaped: a stopped job's id is remembered (the last kStoppedMemory of them) until it starts again.
  Status stop(const std::string& jobId);

  // stop() for every worker, then waits up to `waitSeconds` for them to be reaped. True when none is left.
  bool stopAll(double waitSeconds);

  bool isRunning(const std::string& jobId) const;
  std::vector<std::string> running() const;  // sorted job ids
  double graceSeconds() const { return m_grace; }

 private:
  using SteadyTime = std::chrono::steady_clock::time_point;
  struct Child {
    int pid = 0;
    std::string pidPath;  // <workdir>/<job>.pid while it runs
    std::string logPath;
    long long logOffset = 0;
    SteadyTime started;
    bool stopRequested = false;
    bool killed = false;
    bool exited = false;  // reaped; leaves the table once its exit is handed over
    SteadyTime killAt;
  };
  void reaperLoop();

  ExitCallback m_onExit;
  double m_grace;
  mutable std::mutex m_mutex;
  std::condition_variable m_cv;       // wakes the reaper (stop, shutdown)
  std::condition_variable m_exitedCv; // a child was reaped
  std::map<std::string, Child> m_children;
  static constexpr std::size_t kStoppedMemory = 256;
  std::deque<std::string> m_stoppedEnded;  // jobs that ended after stop(), oldest first
  bool m_quit = false;
  std::thread m_reaper;
};

// Signals every process whose session id is `sid` (read from /proc); returns how many were signalled.
int signalSession(int sid, int sig);

// <workdir>/<job>.pid: the worker's pid (its session id), written at start and removed when it is reaped.
std::string pidFilePath(const std::string& workdir, const std::string& jobId);
// An agent that starts again finds the pid files of the workers its previous run started: each worker still running
// (its command line names the job) is stopped like stop() would (SIGTERM to its session, SIGKILL after
// `graceSeconds`); each one gone is reported as ended while the agent was down. One exit per pid file (code 137,
// the reason saying which), the files removed. The manager requeues such jobs (they resume from their checkpoints).
std::vector<WorkerExit> stopOrphans(const std::string& workdir, double graceSeconds);

}  // namespace pflow::agent
