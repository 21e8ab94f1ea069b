// Scene file (YAML, SI units) -> compute::RunConfig. The format is documented in docs/scene-format.md.
// Every problem is reported at once: parse errors, unknown keys (with a did-you-mean), wrong types, missing keys,
// then RunConfig::validate()'s findings, each with its YAML key path and, where known, line and column.
#pragma once
#include <string>

#include "common/Status.h"
#include "compute/sim/RunConfig.h"

namespace pflow::frontend {

struct LoadedScene {
  compute::RunConfig config;
  std::string sourcePath;  // the file read, or the sourceName given to loadSceneFromString
  std::string outputFile;  // output.file; empty = not given (the CLI's -o decides)
};

// Reads and loads a scene file. I/O problems give StatusCode::kIo, scene problems kInvalidArgument with one error per line.
Result<LoadedScene> loadScene(const std::string& path);

// Loads a scene from YAML text; sourceName names it in messages.
Result<LoadedScene> loadSceneFromString(const std::string& yaml, const std::string& sourceName = "<string>");

}  // namespace pflow::frontend
