// Pieces of pflow-worker that both solvers' run loops use (main.cc: DEM, SphJob.cc: SPH): the progress
// reporter, the stop signal, the failure line the agent reports.
#pragma once
#include <atomic>
#include <condition_variable>
#include <csignal>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "common/Log.h"
#include "common/rpc/Rpc.h"
#include "compute/mpi/MpiDomain.h"
#include "compute/sim/RunConfig.h"
#include "compute/worker/WorkerOptions.h"
#include "frontend/SceneLoader.h"
#include "pflow/manager/v1/node_registry.grpc.pb.h"

namespace pflow::worker {

// SIGTERM or SIGINT (the agent stopping the job, mpirun forwarding it): stop at the next step boundary, close the
// snapshot sink and tell the other ranks, instead of dying mid-write.
extern volatile std::sig_atomic_t g_stopSignal;

// Sends progress to the manager from its own thread, so a slow or unreachable manager never holds up the step
// loop: the loop posts the latest numbers (no wait) and reads the manager's last cancel answer.
class ProgressReporter {
 public:
  ProgressReporter(const std::string& address, std::string jobId, double interval, int attempt = 1)
      : m_jobId(std::move(jobId)), m_interval(interval), m_attempt(attempt) {
    if (address.empty()) return;
    m_stub = manager::v1::NodeRegistry::NewStub(rpc::makeChannel(address));
    m_thread = std::thread([this] { run(); });
  }
  ~ProgressReporter() {
    {
      std::lock_guard lock(m_mu);
      m_stop = true;
    }
    m_cv.notify_all();
    if (m_thread.joinable()) m_thread.join();
  }
  void post(const manager::v1::Progress& p, const std::string& message) {
    std::lock_guard lock(m_mu);
    m_latest = p;
    m_message = message;
    m_fresh = true;
  }
  bool cancelRequested() const { return m_cancel.load(std::memory_order_relaxed); }
  // The last report, sent now and waited for (the run is over).
  void final(const manager::v1::Progress& p, const std::string& message) {
    if (m_stub) send(p, message);
  }

 private:
  void run() {
    std::unique_lock lock(m_mu);
    while (!m_stop) {
      m_cv.wait_for(lock, std::chrono::duration<double>(m_interval), [this] { return m_stop; });
      if (m_stop || !m_fresh) continue;
      const manager::v1::Progress p = m_latest;
      const std::string message = m_message;
      m_fresh = false;
      lock.unlock();
      send(p, message);
      lock.lock();
    }
  }
  void send(const manager::v1::Progress& p, const std::string& message) {
    manager::v1::ReportProgressRequest req;
    req.set_job_id(m_jobId);
    *req.mutable_progress() = p;
    req.set_message(message);
    req.set_attempt(m_attempt);
    manager::v1::ReportProgressResponse resp;
    auto ctx = rpc::contextWithDeadline(5);
    const grpc::Status s = m_stub->ReportProgress(ctx.get(), req, &resp);
    if (!s.ok()) {
      if (!m_warned) spdlog::warn("progress report to the manager failed: {} (the run goes on)", s.error_message());
      m_warned = true;
      return;
    }
    m_warned = false;
    if (resp.cancel()) m_cancel.store(true, std::memory_order_relaxed);
  }

  std::string m_jobId;
  double m_interval;
  int m_attempt;
  std::unique_ptr<manager::v1::NodeRegistry::Stub> m_stub;
  std::mutex m_mu;
  std::condition_variable m_cv;
  manager::v1::Progress m_latest;
  std::string m_message;
  bool m_fresh = false, m_stop = false, m_warned = false;
  std::atomic<bool> m_cancel{false};
  std::thread m_thread;
};

// Where this rank runs: the leased device (a GPU lease runs on that GPU or fails, never silently on the CPU) and,
// with several ranks, the MPI domain over MPI_COMM_WORLD (the scene's decomposition).
struct RankPlacement {
  compute::ExecutorKind executor = compute::ExecutorKind::kCpu;
  int device = 0;
  std::shared_ptr<compute::MpiDomain> domain;  // null: one rank
};
RankPlacement placeRank(const WorkerOptions& o, int rank, int ranks, const compute::RunConfig& config);

// Collective with several ranks: why the run stops, the same on every rank: kStopSignal when a rank saw SIGTERM or
// SIGINT, kStopCancel when the manager asked (either or both); 0 = go on.
inline constexpr int kStopSignal = 1, kStopCancel = 2;
int stopAgreed(bool cancelRequested, const std::shared_ptr<compute::MpiDomain>& domain);
// The exit code of a run that stopped for `why`: 0 when the manager cancelled it (it knows), else 128 + SIGTERM, so
// that the agent or Slurm reports a worker stopped from outside (an agent shutting down, preemption, someone's
// scancel) and the job goes on from its checkpoint instead of counting as finished.
int stoppedExitCode(int why);

// Logs the message, prints it as the last stderr line (the agent reports it) and returns code.
int fail(int code, const std::string& message);

// Runs an SPH job (solver: sph) on this rank: the same sink, progress, cancel and exit codes as DEM's runRank.
// Returns the exit code (the same on every rank), or -1 - code when it stopped early (worker::stoppedExitCode).
int runSphRank(const WorkerOptions& o, int rank, int ranks, const frontend::LoadedScene& scene);

}  // namespace pflow::worker
