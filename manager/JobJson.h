// Jobs and nodes as JSON, the same for the CLI (`--json`) and the web viewer (pflow-web): SI units, times in Unix
// seconds, states in lower case ("running").
#pragma once
#include <nlohmann/json.hpp>

#include "pflow/manager/v1/manager_service.pb.h"

namespace pflow::manager {

const char* stateName(v1::JobState state);  // "queued", "building", ...
nlohmann::json toJson(const v1::Job& job);
nlohmann::json toJson(const v1::Node& node);
nlohmann::json toJson(const v1::JobEvent& event);

}  // namespace pflow::manager
