// Internal to backend/store: the .xmf sidecar of a snapshot file (SnapshotFile.h says what it holds).
#pragma once
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "compute/particles/ParticleSnapshot.h"

namespace pflow::backend::detail {

using compute::ScalarType;

struct ArrayInfo {
  std::string name;
  ScalarType type;
  int components;
};

struct GridInfo {
  std::int64_t step;
  double time;
  std::size_t n;
  std::vector<ArrayInfo> arrays;
};

struct GeometryInfo {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  bool mesh = false, surface = false, material = false;
  bool drawable() const { return vertices > 0 && triangles > 0; }
};

// The whole sidecar for the steps in `grids` and the geometry, naming the .h5 by `h5Name`; `indexSize` is the
// length of /xdmf/polyvertex_index.
std::string buildXdmf(const std::string& h5Name, const std::map<std::int64_t, GridInfo>& grids,
                      const std::optional<GeometryInfo>& geometry, std::uint64_t indexSize);

}  // namespace pflow::backend::detail
