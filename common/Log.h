// One logging facade over spdlog. Host code only: nothing under compute/ kernels logs.
#pragma once
#include <spdlog/spdlog.h>

#include <string>

namespace pflow::log {
// Sets the process-wide pattern with a role prefix ("pflow-run", "rank 3", ...) and the level name.
void init(const std::string& role, const std::string& level = "info");
}  // namespace pflow::log
