#include "frontend/SceneLoader.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "frontend/scene/Loader.h"

namespace pflow::frontend {

Result<LoadedScene> loadScene(const std::string& path, LoadOptions options) {
  std::string text;
  try {
    std::ifstream in(path, std::ios::binary);
    if (!in) return ioError("cannot open scene file '" + path + "': " + std::strerror(errno));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    if (in.bad()) return ioError("cannot read scene file '" + path + "'");
    text = std::move(buffer).str();
  } catch (const std::exception& ex) {
    return ioError("cannot read scene file '" + path + "': " + ex.what());
  }
  options.baseDir = std::filesystem::path(path).parent_path().string();
  return loadSceneFromString(text, path, options);
}

Result<LoadedScene> loadSceneFromString(const std::string& yaml, const std::string& sourceName, const LoadOptions& options) {
  detail::Loader loader(options);
  return loader.run(yaml, sourceName);
}

}  // namespace pflow::frontend
