// The checkpoints of one `pflow run` of either solver (docs/operations.md): the scene of a resumed run, and the
// checkpoint written at the first cell sort after every --checkpoint-every steps or --checkpoint-wall seconds.
#pragma once
#include <chrono>
#include <optional>
#include <string>

#include "backend/store/CheckpointFile.h"
#include "cli/RunCommand.h"
#include "common/Log.h"
#include "compute/sim/CheckpointSchedule.h"
#include "compute/sim/PhaseTimers.h"
#include "frontend/SceneLoader.h"

namespace pflow::cli {

// The scene of a run: its file, or the one the checkpoint of --resume holds (then in `resume`).
Result<frontend::LoadedScene> sceneOf(const RunOptions& o, std::optional<backend::CheckpointData>& resume);

class RunCheckpoints {
 public:
  // `output`: the run's output (the default checkpoint path is beside it); `resume`: the checkpoint resumed from.
  // `everySeconds`: the scene's output.checkpoint_interval (simulated seconds; 0: none).
  static Result<RunCheckpoints> open(const RunOptions& o, const std::string& output, const std::optional<backend::CheckpointData>& resume,
                                     const char* solver, const char* precision, std::int64_t step, double time, double everySeconds);

  // A checkpoint of `sim` if one is due and the step just ended with a cell sort (Simulation, SphSimulation).
  template <class Sim>
  Status maybeWrite(const Sim& sim, compute::PhaseTimers& timers) {
    if (!m_schedule.on() || !sim.justRebuilt() || !m_schedule.due(sim.stepCount(), sim.time())) return Status::ok();
    auto t = timers.time(compute::Phase::kOutput);
    auto state = sim.state();
    if (!state) return state.status();
    m_data.state = std::move(state).value();
    PFLOW_TRY(backend::writeCheckpoint(m_path, m_data));
    m_schedule.taken(sim.stepCount(), sim.time());
    spdlog::info("checkpoint at step {} (t = {:.6g} s) in {}", sim.stepCount(), sim.time(), m_path);
    return Status::ok();
  }

 private:
  compute::CheckpointSchedule m_schedule;
  std::string m_path;
  backend::CheckpointData m_data;  // the scene's text and folder, the solver and precision; the state per write
};

}  // namespace pflow::cli
