#include "manager/GrpcFrontendClient.h"

namespace pflow::manager {

GrpcFrontendClient::GrpcFrontendClient(std::string address, double deadlineSeconds)
    : m_address(std::move(address)), m_deadline(deadlineSeconds) {
  if (!m_address.empty()) m_stub = pflow::frontend::v1::FrontendService::NewStub(rpc::makeChannel(m_address));
}

Result<BuiltModel> GrpcFrontendClient::buildScene(const std::string& sceneYaml, const std::string& sceneName,
                                                  const std::vector<AttachedFile>& files) {
  if (!m_stub) return unavailable("no frontend configured (start the manager with --frontend HOST:PORT)");
  pflow::frontend::v1::BuildSceneRequest req;
  req.set_scene_yaml(sceneYaml);
  req.set_scene_name(sceneName);
  for (const AttachedFile& f : files) {
    auto* a = req.add_files();
    a->set_path(f.path);
    a->set_content(f.content);
  }
  pflow::frontend::v1::BuildSceneResponse resp;
  auto ctx = rpc::contextWithDeadline(m_deadline);
  const grpc::Status s = m_stub->BuildScene(ctx.get(), req, &resp);
  if (!s.ok()) {
    // The frontend answers FAILED_PRECONDITION (invalid scene) or INVALID_ARGUMENT (malformed request) with the
    // scene's errors: for the submitter both mean "the scene is wrong".
    if (s.error_code() == grpc::StatusCode::FAILED_PRECONDITION || s.error_code() == grpc::StatusCode::INVALID_ARGUMENT)
      return invalidArgument("scene '" + sceneName + "' is invalid: " + s.error_message());
    return rpc::fromGrpc(s, "frontend at " + m_address + ": BuildScene");
  }
  BuiltModel m;
  m.modelId = resp.model_id();
  m.modelUri = resp.model_uri();
  m.particles = resp.summary().particles();
  m.memoryBytes = resp.summary().memory_bytes();
  m.steps = resp.summary().steps();
  m.duration = resp.summary().duration();
  m.model = resp.summary().model();
  m.slurm = {resp.summary().slurm_partition(), resp.summary().slurm_account(), resp.summary().slurm_time_limit()};
  return m;
}

}  // namespace pflow::manager
