// FrontendClient over gRPC (FrontendService.BuildScene) with a deadline per call (building a large scene takes a
// while: the bulk deadline by default).
#pragma once
#include <memory>
#include <string>

#include "common/rpc/Rpc.h"
#include "manager/FrontendClient.h"
#include "pflow/frontend/v1/frontend_service.grpc.pb.h"

namespace pflow::manager {

class GrpcFrontendClient final : public FrontendClient {
 public:
  // An empty address gives a client that answers UNAVAILABLE ("no frontend configured").
  explicit GrpcFrontendClient(std::string address, double deadlineSeconds = rpc::kBulkDeadlineSeconds);
  Result<BuiltModel> buildScene(const std::string& sceneYaml, const std::string& sceneName,
                                const std::vector<AttachedFile>& files) override;

 private:
  std::string m_address;
  double m_deadline;
  std::unique_ptr<pflow::frontend::v1::FrontendService::Stub> m_stub;
};

}  // namespace pflow::manager
