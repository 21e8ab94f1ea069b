#include "compute/worker/JobCheckpoints.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace pflow::worker {

namespace fs = std::filesystem;

JobCheckpoints::JobCheckpoints(const WorkerOptions& o, const char* solver, const char* precision, double everySeconds, bool lead,
                               compute::Domain& all)
    : m_jobId(o.jobId), m_solver(solver), m_precision(precision), m_lead(lead), m_resume(o.resume), m_all(all) {
  // Checkpoints need the back-end (a file output is a local run's: `pflow run --checkpoint-every`).
  const double wallSeconds = o.backendAddress.empty() ? 0 : o.checkpointWallSeconds;
  if (o.backendAddress.empty()) {
    everySeconds = 0;
    m_resume = false;
  }
  m_schedule = compute::CheckpointSchedule(0, everySeconds, wallSeconds, 0, 0.0);
  if (!m_lead || (!m_schedule.on() && !m_resume)) return;
  m_backend = backend::makeGrpcBackendClient(o.backendAddress);
  const fs::path scene = fs::path(o.modelDir) / "scene.yaml";
  std::ifstream in(scene, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  m_data.sceneText = text.str();
  m_data.sceneDir = fs::absolute(fs::path(o.modelDir)).string();
  m_data.sceneFile = scene.string();
  m_data.solver = m_solver;
  m_data.precision = m_precision;
  // A local file per job and process (the back-end gets its bytes), in the temporary folder.
  m_path = (fs::temp_directory_path() / ("pflow-" + m_jobId + "-" + std::to_string(::getpid()) + ".ckpt.h5")).string();
  if (m_schedule.on())
    spdlog::info("job {}: checkpoints to the back-end every {}{}{}", m_jobId, wallSeconds > 0 ? fmt::format("{:g} s of wall clock", wallSeconds) : "",
                 wallSeconds > 0 && everySeconds > 0 ? " and every " : "",
                 everySeconds > 0 ? fmt::format("{:g} s of simulated time", everySeconds) : "");
}

JobCheckpoints::~JobCheckpoints() {
  if (m_path.empty()) return;
  std::error_code ec;
  fs::remove(m_path, ec);
}

std::optional<backend::CheckpointData> JobCheckpoints::fetch() {
  if (!m_resume || !m_backend) return std::nullopt;
  const std::string fetched = m_path + ".fetched";
  auto step = m_backend->readCheckpoint(m_jobId, fetched);
  auto fromStart = [&](const std::string& why) -> std::optional<backend::CheckpointData> {
    spdlog::warn("job {}: {}; this attempt starts from the scene's start", m_jobId, why);
    std::error_code ec;
    fs::remove(fetched, ec);
    return std::nullopt;
  };
  if (!step) {
    if (step.status().code() == StatusCode::kNotFound) return fromStart("no checkpoint on the back-end");
    return fromStart("its checkpoint could not be fetched (" + step.status().message() + ")");
  }
  auto data = backend::readCheckpoint(fetched);
  std::error_code ec;
  fs::remove(fetched, ec);
  if (!data) return fromStart("its checkpoint does not read (" + data.status().message() + ")");
  if (data->solver != m_solver || data->precision != m_precision)
    return fromStart("its checkpoint is of a " + data->solver + " run in " + data->precision + " precision, this one is " + m_solver + " in " +
                     m_precision);
  if (data->sceneText != m_data.sceneText) return fromStart("its checkpoint holds another scene than this model's");
  spdlog::info("job {}: fetched its checkpoint of step {} from the back-end", m_jobId, step.value());
  return std::move(data).value();
}

void JobCheckpoints::send(compute::SimulationState state) {
  const std::int64_t step = state.step;
  const double time = state.time;
  if (m_delivered && !m_delivered()) {
    spdlog::warn("job {}: no checkpoint of step {}: earlier output still waits for the back-end in the spool (a resume "
                 "from it would skip that output); the next checkpoint is due on the schedule", m_jobId, step);
    return;
  }
  m_data.state = std::move(state);
  Status s = backend::writeCheckpoint(m_path, m_data, /*scratch=*/true);  // the back-end's copy is the durable one
  m_data.state = {};
  if (s.isOk()) s = m_backend->writeCheckpoint(m_jobId, step, m_path);
  if (!s.isOk()) {
    spdlog::warn("job {}: the checkpoint of step {} did not reach the back-end: {} (the run goes on)", m_jobId, step, s.message());
    return;
  }
  spdlog::info("job {}: checkpoint of step {} (t = {:.6g} s) on the back-end", m_jobId, step, time);
}

}  // namespace pflow::worker
