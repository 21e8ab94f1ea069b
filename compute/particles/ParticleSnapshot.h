// An explicit host copy of particle state (HOOMD SnapshotSystemData role), written by output code.
// Produced from the field table: every field flagged kSnapshot becomes one named array.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "compute/core/VectorMath.h"

namespace pflow::compute {

enum class ScalarType : std::uint8_t { kF64, kF32, kI32, kU64, kU32, kI8 };
constexpr std::size_t scalarBytesOf(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: case ScalarType::kU64: return 8;
    case ScalarType::kF32: case ScalarType::kI32: case ScalarType::kU32: return 4;
    case ScalarType::kI8: return 1;
  }
  return 0;
}
const char* scalarName(ScalarType t);  // "f64", "f32", ...

struct SnapshotArray {
  std::string name;        // dataset name, e.g. "position"
  ScalarType type;         // element scalar type
  int components = 1;      // 3 for vectors
  std::string unit;        // SI unit, e.g. "m", "m/s", "rad/s", "" for dimensionless
  std::vector<std::byte> data;  // n * components * scalarBytesOf(type), row-major (N x components)
  template <class T> const T* as() const { return reinterpret_cast<const T*>(data.data()); }
  template <class T> T* as() { return reinterpret_cast<T*>(data.data()); }
};

struct ParticleSnapshot {
  std::int64_t step = 0;
  double time = 0;  // [s]
  std::size_t n = 0;
  std::vector<SnapshotArray> arrays;
  const SnapshotArray* find(const std::string& name) const {
    for (const auto& a : arrays)
      if (a.name == name) return &a;
    return nullptr;
  }
};

// Rows `rows` of every array of s, in that order (a rank's share of a whole state: SimulationState on resume).
ParticleSnapshot keepSnapshotRows(const ParticleSnapshot& s, const std::vector<std::size_t>& rows);

// Wall geometry at one instant, for output (all meshes concatenated, planes separately).
struct GeometrySnapshot {
  std::vector<Vec3d> vertices;                 // [m]
  std::vector<std::uint32_t> triangles;        // 3 per triangle, into vertices
  std::vector<std::int32_t> triangleMesh;      // mesh index per triangle
  std::vector<std::int32_t> triangleSurface;   // surface number per triangle
  std::vector<std::int32_t> triangleMaterial;  // material index per triangle
  std::vector<std::string> meshNames;
  std::vector<Vec3d> planePoints, planeNormals;
  std::vector<std::string> planeNames;
  std::vector<std::int32_t> planeMaterial;
  std::vector<std::int32_t> planeSurface;  // surface number per plane
  std::vector<std::string> surfaceNames;   // name per surface number
};

}  // namespace pflow::compute
