#include "compute/particles/ParticleSnapshot.h"

#include <cstring>

namespace pflow::compute {

const char* scalarName(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: return "f64";
    case ScalarType::kF32: return "f32";
    case ScalarType::kI32: return "i32";
    case ScalarType::kU64: return "u64";
    case ScalarType::kU32: return "u32";
    case ScalarType::kI8: return "i8";
  }
  return "unknown";
}

ParticleSnapshot keepSnapshotRows(const ParticleSnapshot& s, const std::vector<std::size_t>& rows) {
  ParticleSnapshot out;
  out.step = s.step;
  out.time = s.time;
  out.n = rows.size();
  for (const SnapshotArray& a : s.arrays) {
    const std::size_t row = std::size_t(a.components) * scalarBytesOf(a.type);
    SnapshotArray k{a.name, a.type, a.components, a.unit, std::vector<std::byte>(rows.size() * row)};
    for (std::size_t i = 0; i < rows.size(); ++i) std::memcpy(k.data.data() + i * row, a.data.data() + rows[i] * row, row);
    out.arrays.push_back(std::move(k));
  }
  return out;
}

}  // namespace pflow::compute
