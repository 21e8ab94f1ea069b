#include "common/rpc/Rpc.h"
#include "manager/JobDataClient.h"
#include "pflow/backend/v1/snapshot_service.grpc.pb.h"

namespace pflow::manager {
namespace {

class GrpcJobDataClient final : public JobDataClient {
 public:
  explicit GrpcJobDataClient(const std::string& address)
      : m_address(address), m_stub(backend::v1::SnapshotService::NewStub(rpc::makeChannel(address))) {}

  Status deleteJobData(const std::string& jobId) override {
    backend::v1::DeleteJobDataRequest req;
    req.set_job_id(jobId);
    backend::v1::DeleteJobDataResponse resp;
    auto ctx = rpc::contextWithDeadline();
    return rpc::fromGrpc(m_stub->DeleteJobData(ctx.get(), req, &resp), "deleting the data of " + jobId + " on the back-end " + m_address);
  }

 private:
  std::string m_address;
  std::unique_ptr<backend::v1::SnapshotService::Stub> m_stub;
};

}  // namespace

std::unique_ptr<JobDataClient> makeGrpcJobDataClient(const std::string& address) { return std::make_unique<GrpcJobDataClient>(address); }

}  // namespace pflow::manager
