#include "manager/GrpcAgentClient.h"

#include "manager/ProtoConvert.h"

namespace pflow::manager {

pflow::agent::v1::AgentService::Stub& GrpcAgentClient::stub(const std::string& address) {
  std::lock_guard lock(m_mu);
  auto& s = m_stubs[address];
  if (!s) s = pflow::agent::v1::AgentService::NewStub(rpc::makeChannel(address));
  return *s;
}

Result<std::int64_t> GrpcAgentClient::startJob(const std::string& address, const Lease& lease) {
  if (address.empty()) return unavailable("no agent address for job " + lease.jobId);
  pflow::agent::v1::StartJobRequest req;
  *req.mutable_lease() = toProto(lease);
  pflow::agent::v1::StartJobResponse resp;
  auto ctx = rpc::contextWithDeadline(m_deadline);
  const grpc::Status s = stub(address).StartJob(ctx.get(), req, &resp);
  if (!s.ok()) return rpc::fromGrpc(s, "agent at " + address + ": StartJob");
  return std::int64_t{resp.pid()};
}

Status GrpcAgentClient::stopJob(const std::string& address, const std::string& jobId) {
  if (address.empty()) return unavailable("no agent address for job " + jobId);
  pflow::agent::v1::StopJobRequest req;
  req.set_job_id(jobId);
  pflow::agent::v1::StopJobResponse resp;
  auto ctx = rpc::contextWithDeadline(m_deadline);
  return rpc::fromGrpc(stub(address).StopJob(ctx.get(), req, &resp), "agent at " + address + ": StopJob");
}

}  // namespace pflow::manager
