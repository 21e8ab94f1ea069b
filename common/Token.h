// The shape of a pflow bearer token (manager/Users.h makes them): "pflow_" and 64 lower-case hex digits. What does
// not have it is refused without a lookup (the manager's table, the back-end's call to the manager).
#pragma once
#include <string>

namespace pflow {

inline constexpr const char* kTokenPrefix = "pflow_";

inline bool looksLikeToken(const std::string& token) {
  return token.size() == 70 && token.rfind(kTokenPrefix, 0) == 0 && token.find_first_not_of("0123456789abcdef", 6) == std::string::npos;
}

}  // namespace pflow
