// `pflow run` / `pflow validate` of a solver: sph scene (SphRunCommand.cc); RunCommand.cc dispatches here.
#pragma once
#include <string>

#include "cli/RunCommand.h"
#include "frontend/SceneLoader.h"

namespace pflow::cli {

Result<RunSummary> runSphScene(const RunOptions& options, const frontend::LoadedScene& scene, const std::string& outputPath);
int validateSphScene(const std::string& scenePath, const frontend::LoadedScene& scene, bool json);

}  // namespace pflow::cli
