// An SPH scene file loaded at another particle spacing (its `spacing:` replaced), as `pflow run` loads it: what
// pflow-sph-bench and pflow-sph-lanes share. Errors name the file.
#pragma once
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "common/Status.h"
#include "frontend/SceneLoader.h"

namespace pflow::bench {

inline Result<compute::RunConfig> loadSphSceneAt(const std::string& path, double spacing) {
  std::ifstream in(path);
  if (!in) return ioError("cannot read " + path);
  std::stringstream text;
  text << in.rdbuf();
  char value[64];
  std::snprintf(value, sizeof value, "spacing: %.9g", spacing);
  frontend::LoadOptions lo;
  lo.baseDir = ".";
  auto loaded = frontend::loadSceneFromString(std::regex_replace(text.str(), std::regex("spacing: [0-9.eE+-]+"), value), path, lo);
  if (!loaded) return loaded.status();
  return loaded.value().config;
}

}  // namespace pflow::bench
