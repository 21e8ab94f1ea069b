#include "cli/RunCheckpoints.h"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace pflow::cli {

namespace fs = std::filesystem;

Result<frontend::LoadedScene> sceneOf(const RunOptions& o, std::optional<backend::CheckpointData>& resume) {
  if (o.resumePath.empty()) {
    if (o.scenePath.empty()) return invalidArgument("pflow run: give a scene file, or --resume CHECKPOINT");
    return frontend::loadScene(o.scenePath);
  }
  if (!o.scenePath.empty()) return invalidArgument("pflow run --resume: the scene is the checkpoint's; give no scene file");
  if (o.outputPath.empty()) return invalidArgument("pflow run --resume: name the output file (-o OUT.h5): the first run's is not overwritten");
  std::string skipped;
  auto data = backend::readLatestCheckpoint(o.resumePath, &skipped);
  if (!data) return data.status();
  if (!skipped.empty()) spdlog::warn("{}; resuming from the checkpoint before it, {}", skipped, backend::previousCheckpointPath(o.resumePath));
  frontend::LoadOptions lo;
  lo.baseDir = data.value().sceneDir;
  auto scene = frontend::loadSceneFromString(data.value().sceneText, data.value().sceneFile, lo);
  if (!scene) return Status(scene.status().code(), "the checkpoint's scene: " + scene.status().message());
  const bool sph = scene.value().config.solver == compute::Solver::kSph;
  if (data.value().solver != (sph ? "sph" : "dem"))
    return invalidArgument("the checkpoint '" + o.resumePath + "' says solver " + data.value().solver + " but holds a scene of the other");
  resume = std::move(data).value();
  return scene;
}

Result<RunCheckpoints> RunCheckpoints::open(const RunOptions& o, const std::string& output, const std::optional<backend::CheckpointData>& resume,
                                            const char* solver, const char* precision, std::int64_t step, double time,
                                            double everySeconds) {
  RunCheckpoints c;
  if (resume && resume->precision != precision)
    return invalidArgument("pflow run --resume: the checkpoint was taken in " + resume->precision + " precision, this run is " + precision);
  c.m_schedule = compute::CheckpointSchedule(o.checkpointEvery, everySeconds, o.checkpointWallSeconds, step, time);
  if (!o.checkpointPath.empty()) {
    c.m_path = o.checkpointPath;
  } else {
    const fs::path p(output);
    c.m_path = (p.parent_path() / (p.stem().string() + ".ckpt.h5")).string();
  }
  if (!c.m_schedule.on()) return c;
  if (resume) {
    c.m_data = *resume;
    c.m_data.state = {};
  } else {
    std::ifstream in(o.scenePath, std::ios::binary);
    if (!in) return ioError("cannot read '" + o.scenePath + "'");
    std::stringstream text;
    text << in.rdbuf();
    c.m_data.sceneText = text.str();
    c.m_data.sceneDir = fs::absolute(fs::path(o.scenePath)).parent_path().string();
    c.m_data.sceneFile = o.scenePath;
  }
  c.m_data.solver = solver;
  c.m_data.precision = precision;
  if (o.checkpointEvery > 0)
    spdlog::info("a checkpoint at the first cell sort after every {} steps, into {}", o.checkpointEvery, c.m_path);
  if (everySeconds > 0)
    spdlog::info("a checkpoint at the first cell sort after every {} s of simulated time (output.checkpoint_interval), into {}",
                 everySeconds, c.m_path);
  return c;
}

}  // namespace pflow::cli
