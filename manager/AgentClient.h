// What the manager asks of node agents. GrpcAgentClient is the real one; tests use a fake. Implementations must be
// thread-safe and give every call a deadline.
#pragma once
#include <cstdint>
#include <string>

#include "common/Status.h"
#include "manager/Types.h"

namespace pflow::manager {

class AgentClient {
 public:
  virtual ~AgentClient() = default;
  // Starts the job's worker on the agent at `address` (host:port); returns its pid. ALREADY_EXISTS when the job
  // already runs there (the manager treats that as started).
  virtual Result<std::int64_t> startJob(const std::string& address, const Lease& lease) = 0;
  // Stops the job's worker. NOT_FOUND when it does not run there.
  virtual Status stopJob(const std::string& address, const std::string& jobId) = 0;
};

}  // namespace pflow::manager
