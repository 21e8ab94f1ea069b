#include "compute/particles/ParticleSnapshot.h"

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

}  // namespace pflow::compute
