// Helpers the Manager's two files share (Manager.cc: state changes, agents and nodes; ManagerJobs.cc: submissions
// and what users do with their jobs). Internal to pflow_manager.
#pragma once
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "common/Log.h"
#include "common/Status.h"
#include "manager/Types.h"

namespace pflow::manager::detail {

// A job id as requests carry it: short and printable (the ids the manager makes are job-NNNNNN); never echoed raw.
inline Status checkJobIdField(const std::string& id) {
  if (id.empty()) return invalidArgument("job id is empty");
  if (id.size() > 64 || !log::isPrintable(id)) return invalidArgument("job id '" + log::escaped(id, 64) + "' is not a job id (job-NNNNNN)");
  return Status::ok();
}

inline std::string jobIdFor(std::int64_t seq) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "job-%06lld", static_cast<long long>(seq));
  return buf;
}

inline std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", s);
  return buf;
}

inline std::string describeDevices(const std::vector<DeviceKey>& devices) {
  std::string out;
  for (const DeviceKey& d : devices) out += (out.empty() ? "" : ", ") + d.toString();
  return out;
}

inline std::set<std::string> nodesOf(const Job& job) {
  std::set<std::string> out;
  for (const DeviceKey& d : job.devices) out.insert(d.node);
  return out;
}

inline std::string leadNode(const Job& job) { return job.devices.empty() ? std::string() : job.devices.front().node; }

}  // namespace pflow::manager::detail
