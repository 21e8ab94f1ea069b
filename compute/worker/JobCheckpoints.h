// A job's checkpoints through the back-end (issue 18; docs/operations.md, "Checkpoints of jobs"), for both solvers'
// run loops (main.cc: DEM, SphJob.cc: SPH).
//   - Taking one: on the schedule of --checkpoint-wall (wall clock, 600 s by default) and the scene's
//     output.checkpoint_interval (simulated seconds), at the first step after it that ended with a cell sort. The
//     decision is rank 0's (its clock), shared by one reduction at such steps only; the state is gathered to rank 0
//     (collective), written to a local file (CheckpointFile.h), and sent to the back-end, which keeps the job's last
//     two. A checkpoint that cannot be written or sent is logged and the run goes on: it costs the run nothing but
//     the protection.
//   - Resuming (--resume, which the agent passes when the manager requeued the job): rank 0 fetches the job's latest
//     checkpoint from the back-end; every rank resumes from it (the rows split over this run's ranks, whatever their
//     number). With no checkpoint, or one that does not belong to this model, the run starts from the scene's start.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "backend/BackendClient.h"
#include "backend/store/CheckpointFile.h"
#include "common/Log.h"
#include "compute/sim/CheckpointSchedule.h"
#include "compute/sim/Domain.h"
#include "compute/sim/PhaseTimers.h"
#include "compute/worker/WorkerOptions.h"

namespace pflow::worker {

class JobCheckpoints {
 public:
  // `solver`: "dem" | "sph"; `precision`: the run's ("float" | "double"); `everySeconds`: the scene's
  // output.checkpoint_interval (0: none).
  JobCheckpoints(const WorkerOptions& o, const char* solver, const char* precision, double everySeconds, bool lead, compute::Domain& all);
  ~JobCheckpoints();
  // Asked (on rank 0) before a checkpoint is sent: whether every snapshot and series written so far has reached the
  // back-end (SnapshotSink::delivered). A checkpoint past a snapshot still in the worker's spool would let a resumed
  // run skip that snapshot for good if the worker died with its spool; such a checkpoint is not sent.
  void setOutputsDelivered(std::function<bool()> delivered) { m_delivered = std::move(delivered); }

  // With --resume: the run `sim` (just created from the model) goes on from the job's latest checkpoint. Collective.
  // Returns whether it resumed (the same on every rank); an error only when the resume itself failed midway.
  template <class Sim>
  Result<bool> resume(Sim& sim) {
    const std::optional<backend::CheckpointData> data = m_lead ? fetch() : std::nullopt;
    if (m_all.sum(data ? 1.0 : 0.0) == 0) return false;
    static const compute::SimulationState kNone;
    PFLOW_TRY(sim.resume(data ? data->state : kNone));
    m_schedule.taken(sim.stepCount(), sim.time());  // the next one counted from the resume point
    if (m_lead) spdlog::info("job {} resumed from its checkpoint at step {} (t = {:.6g} s)", m_jobId, sim.stepCount(), sim.time());
    return true;
  }

  // A checkpoint of `sim` if one is due and the step ended with a cell sort. Collective (at such steps only).
  template <class Sim>
  void maybeTake(const Sim& sim, compute::PhaseTimers& timers) {
    if (!m_schedule.on() || !sim.justRebuilt()) return;
    const bool due = m_lead && m_schedule.due(sim.stepCount(), sim.time());
    if (m_all.sum(due ? 1.0 : 0.0) == 0) return;
    auto t = timers.time(compute::Phase::kOutput);
    auto state = sim.state();  // collective: the rows gathered on rank 0
    m_schedule.taken(sim.stepCount(), sim.time());
    if (!m_lead) return;
    if (!state) {
      spdlog::warn("job {}: no checkpoint at step {}: {}", m_jobId, sim.stepCount(), state.status().message());
      return;
    }
    send(std::move(state).value());
  }

 private:
  std::optional<backend::CheckpointData> fetch();
  void send(compute::SimulationState state);

  std::string m_jobId, m_solver, m_precision, m_path;
  bool m_lead, m_resume;
  compute::Domain& m_all;
  compute::CheckpointSchedule m_schedule;
  backend::CheckpointData m_data;  // the scene and the run's kind; the state per checkpoint
  std::unique_ptr<backend::BackendClient> m_backend;
  std::function<bool()> m_delivered;
};

}  // namespace pflow::worker
