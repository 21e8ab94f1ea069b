#include "manager/Types.h"

namespace pflow::manager {

const char* deviceKindName(DeviceKind kind) { return kind == DeviceKind::kGpu ? "GPU" : "CPU"; }

std::string DeviceKey::toString() const { return node + "/" + deviceKindName(kind) + " " + std::to_string(index); }

const char* deviceStateName(DeviceState state) {
  switch (state) {
    case DeviceState::kFree: return "FREE";
    case DeviceState::kBusy: return "BUSY";
    case DeviceState::kLost: return "LOST";
  }
  return "?";
}

namespace {
constexpr JobState kAllStates[] = {JobState::kQueued,    JobState::kStarting,   JobState::kRunning,  JobState::kSucceeded,
                                   JobState::kFailed,    JobState::kCancelling, JobState::kCancelled, JobState::kRequeued,
                                   JobState::kBuilding};
}

const char* jobStateName(JobState state) {
  switch (state) {
    case JobState::kQueued: return "QUEUED";
    case JobState::kStarting: return "STARTING";
    case JobState::kRunning: return "RUNNING";
    case JobState::kSucceeded: return "SUCCEEDED";
    case JobState::kFailed: return "FAILED";
    case JobState::kCancelling: return "CANCELLING";
    case JobState::kCancelled: return "CANCELLED";
    case JobState::kRequeued: return "REQUEUED";
    case JobState::kBuilding: return "BUILDING";
  }
  return "?";
}

std::optional<JobState> jobStateFromName(const std::string& name) {
  for (JobState s : kAllStates)
    if (name == jobStateName(s)) return s;
  return std::nullopt;
}

bool isFinal(JobState s) { return s == JobState::kSucceeded || s == JobState::kFailed || s == JobState::kCancelled; }

bool isWaiting(JobState s) { return s == JobState::kQueued || s == JobState::kRequeued; }

bool holdsDevices(JobState s) {
  return s == JobState::kStarting || s == JobState::kRunning || s == JobState::kCancelling;
}


}  // namespace pflow::manager
