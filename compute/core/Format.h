// Short number, vector and key-path formatting for user-facing messages (validation, errors).
#pragma once
#include <cstdio>
#include <string>

#include "compute/core/VectorMath.h"

namespace pflow::format {

// 6 significant digits, e.g. 4.8e+10, 0.001.
inline std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}
// 4 significant digits, e.g. 39.62, 7.572e-05: the model's decisions and summaries.
inline std::string num4(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}
// [x, y, z]. Built by appending: GCC 12 warns falsely (-Wrestrict, PR105329) on "[" + std::string chains.
inline std::string vec(const Vec3d& v) {
  std::string out = "[";
  out.append(num(v.x)).append(", ").append(num(v.y)).append(", ").append(num(v.z)).append("]");
  return out;
}
// base[i], for key paths such as particles.radius[12].
inline std::string at(const std::string& base, std::size_t i) { return base + "[" + std::to_string(i) + "]"; }

}  // namespace pflow::format
