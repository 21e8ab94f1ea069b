// gRPC adapter for pflow.frontend.v1.FrontendService (callback API): proto in -> loadScene / summarize /
// ModelStore -> proto out. No scene logic here.
#pragma once
#include <memory>

#include "frontend/service/ModelStore.h"
#include "pflow/frontend/v1/frontend_service.grpc.pb.h"

namespace pflow::frontend {

class FrontendServiceImpl final : public pflow::frontend::v1::FrontendService::CallbackService {
 public:
  explicit FrontendServiceImpl(ModelStore& store) : m_store(store) {}

  grpc::ServerUnaryReactor* ValidateScene(grpc::CallbackServerContext* ctx, const v1::ValidateSceneRequest* req,
                                          v1::ValidateSceneResponse* resp) override;
  grpc::ServerUnaryReactor* BuildScene(grpc::CallbackServerContext* ctx, const v1::BuildSceneRequest* req,
                                       v1::BuildSceneResponse* resp) override;

 private:
  ModelStore& m_store;
};

}  // namespace pflow::frontend
