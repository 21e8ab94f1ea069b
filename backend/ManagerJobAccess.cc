#include "backend/JobAccess.h"
#include "common/Token.h"
#include "common/rpc/Rpc.h"
#include "pflow/manager/v1/manager_service.grpc.pb.h"

namespace pflow::backend {
namespace {

class ManagerJobAccess final : public JobAccess {
 public:
  explicit ManagerJobAccess(const std::string& address)
      : m_address(address), m_stub(manager::v1::ManagerService::NewStub(rpc::makeChannel(address))) {}

  Status mayRead(const std::string& token, const std::string& jobId) override {
    if (token.empty()) return unauthenticated("no token: set PFLOW_TOKEN or `token:` in ~/.config/pflow/config.yaml");
    // Not a token's shape: refused here, without holding an executor thread on a call to the manager.
    if (!looksLikeToken(token)) return unauthenticated("the token is not valid");
    auto ctx = rpc::contextWithDeadline(5);
    rpc::addBearer(*ctx, token);
    manager::v1::GetJobRequest req;
    req.set_id(jobId);
    manager::v1::Job job;
    const grpc::Status s = m_stub->GetJob(ctx.get(), req, &job);
    if (s.ok()) return Status::ok();
    if (s.error_code() == grpc::StatusCode::UNAVAILABLE || s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)
      return unavailable("cannot ask the manager at " + m_address + " whether the caller may read job " + jobId);
    return rpc::fromGrpc(s);
  }

 private:
  std::string m_address;
  std::unique_ptr<manager::v1::ManagerService::Stub> m_stub;
};

}  // namespace

std::unique_ptr<JobAccess> makeManagerJobAccess(const std::string& managerAddress) {
  return std::make_unique<ManagerJobAccess>(managerAddress);
}

}  // namespace pflow::backend
