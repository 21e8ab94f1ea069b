// The agent's gRPC face: a thin adapter (callback API) over Agent, and the NodeRegistry client it reports through.
#pragma once
#include <memory>
#include <string>

#include "manager/agent/Agent.h"
#include "pflow/agent/v1/agent_service.grpc.pb.h"
#include "pflow/manager/v1/node_registry.grpc.pb.h"

namespace pflow::agent {

class AgentService final : public pflow::agent::v1::AgentService::CallbackService {
 public:
  explicit AgentService(Agent& agent) : m_agent(agent) {}

  grpc::ServerUnaryReactor* GetDevices(grpc::CallbackServerContext* ctx, const pflow::agent::v1::GetDevicesRequest* req,
                                       pflow::agent::v1::GetDevicesResponse* resp) override;
  grpc::ServerUnaryReactor* StartJob(grpc::CallbackServerContext* ctx, const pflow::agent::v1::StartJobRequest* req,
                                     pflow::agent::v1::StartJobResponse* resp) override;
  grpc::ServerUnaryReactor* StopJob(grpc::CallbackServerContext* ctx, const pflow::agent::v1::StopJobRequest* req,
                                    pflow::agent::v1::StopJobResponse* resp) override;

 private:
  Agent& m_agent;
};

// RegistryClient over gRPC: every call has a deadline (heartbeats: `heartbeatDeadline`, exit reports:
// `reportDeadline`); Agent retries exit reports that did not get an answer.
class GrpcRegistryClient final : public RegistryClient {
 public:
  explicit GrpcRegistryClient(const std::string& managerAddress, double heartbeatDeadline = 5, double reportDeadline = 10);
  Result<HeartbeatReply> heartbeat(const HeartbeatPayload& payload) override;
  Status reportJobExit(const JobExitReport& report) override;

 private:
  std::string m_address;
  double m_heartbeatDeadline;
  double m_reportDeadline;
  std::unique_ptr<pflow::manager::v1::NodeRegistry::Stub> m_stub;
};

}  // namespace pflow::agent
