// What the manager asks of the frontend: build a scene into a model workers can read. GrpcFrontendClient is the real
// one; tests use a fake. Implementations must be thread-safe and give every call a deadline.
#pragma once
#include <string>
#include <vector>

#include "common/Status.h"
#include "manager/Types.h"

namespace pflow::manager {

class FrontendClient {
 public:
  virtual ~FrontendClient() = default;
  // INVALID_ARGUMENT listing the scene's errors when it is invalid; UNAVAILABLE when the frontend cannot be reached.
  virtual Result<BuiltModel> buildScene(const std::string& sceneYaml, const std::string& sceneName,
                                        const std::vector<AttachedFile>& files) = 0;
};

}  // namespace pflow::manager
