// AgentClient over gRPC: one channel per agent address (cached), every call with a deadline.
#pragma once
#include <map>
#include <memory>
#include <mutex>

#include "common/rpc/Rpc.h"
#include "manager/AgentClient.h"
#include "pflow/agent/v1/agent_service.grpc.pb.h"

namespace pflow::manager {

class GrpcAgentClient final : public AgentClient {
 public:
  explicit GrpcAgentClient(double deadlineSeconds = rpc::kControlDeadlineSeconds) : m_deadline(deadlineSeconds) {}
  Result<std::int64_t> startJob(const std::string& address, const Lease& lease) override;
  Status stopJob(const std::string& address, const std::string& jobId) override;

 private:
  pflow::agent::v1::AgentService::Stub& stub(const std::string& address);
  double m_deadline;
  std::mutex m_mu;
  std::map<std::string, std::unique_ptr<pflow::agent::v1::AgentService::Stub>> m_stubs;
};

}  // namespace pflow::manager
