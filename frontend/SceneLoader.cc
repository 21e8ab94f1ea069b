#include "frontend/SceneLoader.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "frontend/scene/Loader.h"

namespace pflow::frontend {

Result<LoadedScene> loadScene(const std::string& path) {
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
  return loadSceneFromString(text, path, std::filesystem::path(path).parent_path().string());
}

Result<LoadedScene> loadSceneFromString(const std::string& yaml, const std::string& sourceName, const std::string& baseDir) {
  detail::Loader loader(baseDir);
  return loader.run(yaml, sourceName);
}

}  // namespace pflow::frontend
