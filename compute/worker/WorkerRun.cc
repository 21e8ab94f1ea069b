#include "compute/worker/WorkerRun.h"

#include <cstdio>

namespace pflow::worker {

volatile std::sig_atomic_t g_stopSignal = 0;

int fail(int code, const std::string& message) {
  spdlog::error("{}", message);
  std::fprintf(stderr, "%s\n", message.c_str());  // the agent reports the last stderr line
  return code;
}

}  // namespace pflow::worker
