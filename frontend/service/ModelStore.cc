#include "frontend/service/ModelStore.h"

#include "common/Log.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "frontend/service/InitialState.h"

namespace pflow::frontend {

namespace fs = std::filesystem;

namespace {

Status writeFile(const fs::path& path, const std::string& bytes) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) return ioError("cannot create '" + path.parent_path().string() + "': " + ec.message());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) return ioError("cannot write '" + path.string() + "'");
  return Status::ok();
}

std::string uniqueSuffix() {
  static std::atomic<unsigned> counter{0};
  return std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

}  // namespace

ModelStore::ModelStore(std::string root) : m_root(fs::absolute(root).lexically_normal().string()) {}

Status ModelStore::checkRelative(const std::string& path) {
  if (path.empty()) return invalidArgument("an attached file has an empty path");
  if (path.size() > 1024 || !log::isPrintable(path))
    return invalidArgument("attached file '" + log::escaped(path, 100) + "': at most 1024 printable ASCII characters");
  const fs::path p(path);
  if (p.is_absolute()) return invalidArgument("attached file '" + path + "': the path must be relative to the scene");
  for (const auto& part : p) {
    if (part == "..") return invalidArgument("attached file '" + path + "': '..' is not allowed");
    if (part.string().size() > 255) return invalidArgument("attached file '" + log::escaped(path, 100) + "': a name longer than 255 characters");
  }
  if (p.filename().empty() || p.filename() == ".") return invalidArgument("attached file '" + path + "': names a folder, not a file");
  // The model's own files: an attachment of that name would replace what was checked.
  for (const char* reserved : {"scene.yaml", "initial.h5", "summary.json"})
    if (p.lexically_normal() == fs::path(reserved))
      return invalidArgument("attached file '" + path + "': the name is the model's own; rename the file and the scene's reference to it");
  return Status::ok();
}

std::string ModelStore::contentId(const std::string& sceneYaml, const std::vector<SceneFile>& files) {
  // FNV-1a 64 over length-prefixed parts: the scene, then each file's path and content, in path order.
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&](const std::string& s) {
    const std::uint64_t n = s.size();
    for (int b = 0; b < 8; ++b) h = (h ^ ((n >> (8 * b)) & 0xff)) * 1099511628211ull;
    for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  };
  mix(sceneYaml);
  std::vector<const SceneFile*> sorted;
  for (const auto& f : files) sorted.push_back(&f);
  std::sort(sorted.begin(), sorted.end(), [](auto* a, auto* b) { return a->path < b->path; });
  for (const SceneFile* f : sorted) {
    mix(f->path);
    mix(f->content);
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

Result<std::string> ModelStore::stage(const std::vector<SceneFile>& files) const {
  for (const auto& f : files)
    if (Status s = checkRelative(f.path); !s.isOk()) return s;
  const fs::path dir = fs::path(m_root) / (".staging-" + uniqueSuffix());
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return ioError("cannot create the staging folder '" + dir.string() + "': " + ec.message());
  for (const auto& f : files)
    if (Status s = writeFile(dir / f.path, f.content); !s.isOk()) return s;
  return dir.string();
}

Result<StoredModel> ModelStore::put(const std::string& sceneYaml, const std::vector<SceneFile>& files, const LoadedScene& scene,
                                    const std::string& summaryJson) {
  StoredModel m;
  m.id = contentId(sceneYaml, files);
  const fs::path dir = fs::path(m_root) / m.id;
  m.dir = dir.string();
  m.scenePath = (dir / "scene.yaml").string();
  if (fs::exists(dir / "summary.json")) return m;  // stored before: content-addressed
  // Build in a temporary folder and rename, so a reader never sees half a model.
  const fs::path tmp = fs::path(m_root) / (".building-" + m.id + "-" + uniqueSuffix());
  std::error_code ec;
  fs::create_directories(tmp, ec);
  if (ec) return ioError("cannot create '" + tmp.string() + "': " + ec.message());
  Status s = writeFile(tmp / "scene.yaml", sceneYaml);
  for (const auto& f : files)
    if (s.isOk()) s = checkRelative(f.path).isOk() ? writeFile(tmp / f.path, f.content) : checkRelative(f.path);
  if (s.isOk()) s = writeInitialState(scene, (tmp / "initial.h5").string());
  if (s.isOk()) s = writeFile(tmp / "summary.json", summaryJson);
  if (s.isOk()) {
    fs::rename(tmp, dir, ec);
    if (ec && !fs::exists(dir / "summary.json")) s = ioError("cannot store the model in '" + dir.string() + "': " + ec.message());
  }
  fs::remove_all(tmp, ec);
  if (!s.isOk()) return s;
  return m;
}

}  // namespace pflow::frontend
