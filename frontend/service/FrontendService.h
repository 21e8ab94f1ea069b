// gRPC adapter for pflow.frontend.v1.FrontendService (callback API): proto in -> loadScene / summarize /
// ModelStore -> proto out. No scene logic here. The work runs on a pool of its own, never on gRPC's threads; a
// call whose deadline passed while it waited is answered DEADLINE_EXCEEDED without being loaded.
#pragma once
#include <memory>

#include "common/Status.h"
#include "common/TaskPool.h"
#include "frontend/service/ModelStore.h"
#include "pflow/frontend/v1/frontend_service.grpc.pb.h"

namespace pflow::frontend {

class FrontendServiceImpl final : public pflow::frontend::v1::FrontendService::CallbackService {
 public:
  explicit FrontendServiceImpl(ModelStore& store, int workers = 2) : m_store(store), m_pool(std::make_unique<TaskPool>(workers)) {}

  grpc::ServerUnaryReactor* ValidateScene(grpc::CallbackServerContext* ctx, const v1::ValidateSceneRequest* req,
                                          v1::ValidateSceneResponse* resp) override;
  grpc::ServerUnaryReactor* BuildScene(grpc::CallbackServerContext* ctx, const v1::BuildSceneRequest* req,
                                       v1::BuildSceneResponse* resp) override;

 private:
  Status validate(const v1::ValidateSceneRequest& req, v1::ValidateSceneResponse* resp);
  Status build(const v1::BuildSceneRequest& req, v1::BuildSceneResponse* resp);
  template <class Work>
  grpc::ServerUnaryReactor* onPool(grpc::CallbackServerContext* ctx, const char* what, Work work);
  ModelStore& m_store;
  std::unique_ptr<TaskPool> m_pool;  // last: joined before the store goes
};

}  // namespace pflow::frontend
