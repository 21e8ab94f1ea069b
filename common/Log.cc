#include "common/Log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace pflow::log {
void init(const std::string& role, const std::string& level) {
  auto logger = spdlog::stderr_color_mt(role);
  logger->set_pattern("[%H:%M:%S.%e] [" + role + "] [%^%l%$] %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(level));
}
}  // namespace pflow::log
