// Scalar type helpers for ParticleSnapshot. Built into pflow_snapshot_io for now; the core library will own it.
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::compute {

std::size_t scalarBytes(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: return 8;
    case ScalarType::kF32: return 4;
    case ScalarType::kI32: return 4;
    case ScalarType::kU64: return 8;
    case ScalarType::kU32: return 4;
    case ScalarType::kI8: return 1;
  }
  return 0;
}

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

}  // namespace pflow::compute
