// host:port addresses as the services and the CLI write them.
#pragma once
#include <string>

namespace pflow {

// The host part of host:port ("[::1]:50051" keeps its brackets; an address without a port is its own host).
inline std::string hostOf(const std::string& address) {
  if (!address.empty() && address.front() == '[') {
    const auto close = address.find(']');
    return close == std::string::npos ? address : address.substr(0, close + 1);
  }
  const auto colon = address.rfind(':');
  return colon == std::string::npos ? address : address.substr(0, colon);
}

}  // namespace pflow
