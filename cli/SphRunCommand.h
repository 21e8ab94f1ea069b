// `pflow run` / `pflow validate` of a solver: sph scene (SphRunCommand.cc); RunCommand.cc dispatches here.
#pragma once
#include <optional>
#include <string>

#include "backend/store/CheckpointFile.h"
#include "cli/RunCommand.h"
#include "frontend/SceneLoader.h"

namespace pflow::cli {

// `resume`: the checkpoint the run goes on from (RunCheckpoints.h: sceneOf), if any.
Result<RunSummary> runSphScene(const RunOptions& options, const frontend::LoadedScene& scene, const std::string& outputPath,
                               const std::optional<backend::CheckpointData>& resume = std::nullopt);
int validateSphScene(const std::string& scenePath, const frontend::LoadedScene& scene, bool json);

}  // namespace pflow::cli
