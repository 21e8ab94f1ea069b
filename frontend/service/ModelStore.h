// Built models, stored where workers read them: <root>/<model_id>/ holds scene.yaml, the files it refers to (at
// their relative paths), initial.h5 (+ .xmf, the initial state for ParaView) and summary.json. The id is a content
// hash of the scene text and its files, so the same submission is stored once.
#pragma once
#include <string>
#include <vector>

#include "common/Status.h"
#include "frontend/SceneLoader.h"

namespace pflow::frontend {

struct SceneFile {
  std::string path;     // relative, as the scene refers to it
  std::string content;  // bytes
};

struct StoredModel {
  std::string id;
  std::string dir;        // absolute path of the model folder (the model URI workers get)
  std::string scenePath;  // dir/scene.yaml
};

class ModelStore {
 public:
  explicit ModelStore(std::string root);
  const std::string& root() const { return m_root; }

  // Writes `files` into a fresh temporary folder under the root (relative paths only, no '..'), so that a scene
  // can be loaded with its files before it is stored; returns that folder. Caller removes it (or passes it to put).
  Result<std::string> stage(const std::vector<SceneFile>& files) const;
  // Stores a loaded scene (its text and files) as a model; `summaryJson` goes beside it. Idempotent per content.
  Result<StoredModel> put(const std::string& sceneYaml, const std::vector<SceneFile>& files, const LoadedScene& scene,
                          const std::string& summaryJson);

  static std::string contentId(const std::string& sceneYaml, const std::vector<SceneFile>& files);
  // A relative path that stays inside its folder: not empty, not absolute, no '..' component.
  static Status checkRelative(const std::string& path);

 private:
  std::string m_root;
};

}  // namespace pflow::frontend
