// Whether a user may read a job's snapshots (docs/security.md). The back-end does not know users or owners; the
// manager does, so the back-end asks it, passing the user's token on. Blocking: call it on the back-end's executor,
// never on a gRPC callback thread.
#pragma once
#include <memory>
#include <string>

#include "common/Status.h"

namespace pflow::backend {

class JobAccess {
 public:
  virtual ~JobAccess() = default;
  // OK when the user of `token` may read job `jobId` (its owner or an admin); UNAUTHENTICATED, PERMISSION_DENIED,
  // NOT_FOUND or UNAVAILABLE (the manager cannot be asked) otherwise.
  virtual Status mayRead(const std::string& token, const std::string& jobId) = 0;
};

// Asks the manager at `managerAddress` (ManagerService.GetJob with the user's token).
std::unique_ptr<JobAccess> makeManagerJobAccess(const std::string& managerAddress);

}  // namespace pflow::backend
