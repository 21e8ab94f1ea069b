#include "manager/agent/AgentService.h"

#include "common/rpc/Rpc.h"
#include "manager/agent/AgentProto.h"

namespace pflow::agent {

namespace av1 = pflow::agent::v1;
namespace mv1 = pflow::manager::v1;

namespace {
grpc::ServerUnaryReactor* finish(grpc::CallbackServerContext* ctx, const Status& s) {
  auto* reactor = ctx->DefaultReactor();
  reactor->Finish(rpc::toGrpc(s));
  return reactor;
}
}  // namespace

grpc::ServerUnaryReactor* AgentService::GetDevices(grpc::CallbackServerContext* ctx, const av1::GetDevicesRequest*,
                                                   av1::GetDevicesResponse* resp) {
  if (Status who = rpc::requirePeer(*ctx, "the agent", rpc::kManagerIdentity); !who) return finish(ctx, who);
  resp->set_node(m_agent.node());
  for (const DeviceStatus& d : m_agent.devices()) toProto(d, m_agent.node(), resp->add_devices());
  return finish(ctx, Status::ok());
}

grpc::ServerUnaryReactor* AgentService::StartJob(grpc::CallbackServerContext* ctx, const av1::StartJobRequest* req,
                                                 av1::StartJobResponse* resp) {
  // A lease starts a process on this node: only the manager may give one.
  if (Status who = rpc::requirePeer(*ctx, "the agent", rpc::kManagerIdentity); !who) return finish(ctx, who);
  Result<Lease> lease = fromProto(req->lease());
  if (!lease) return finish(ctx, lease.status());
  Result<int> pid = m_agent.startJob(lease.value());
  if (pid) resp->set_pid(pid.value());
  return finish(ctx, pid.status());
}

grpc::ServerUnaryReactor* AgentService::StopJob(grpc::CallbackServerContext* ctx, const av1::StopJobRequest* req,
                                                av1::StopJobResponse*) {
  if (Status who = rpc::requirePeer(*ctx, "the agent", rpc::kManagerIdentity); !who) return finish(ctx, who);
  return finish(ctx, m_agent.stopJob(req->job_id()));
}

GrpcRegistryClient::GrpcRegistryClient(const std::string& managerAddress, double heartbeatDeadline, double reportDeadline)
    : m_address(managerAddress),
      m_heartbeatDeadline(heartbeatDeadline),
      m_reportDeadline(reportDeadline),
      m_stub(mv1::NodeRegistry::NewStub(rpc::makeChannel(managerAddress))) {}

Result<HeartbeatReply> GrpcRegistryClient::heartbeat(const HeartbeatPayload& payload) {
  mv1::HeartbeatRequest req;
  toProto(payload, &req);
  mv1::HeartbeatResponse resp;
  auto ctx = rpc::contextWithDeadline(m_heartbeatDeadline);
  const grpc::Status s = m_stub->Heartbeat(ctx.get(), req, &resp);
  if (!s.ok()) return rpc::fromGrpc(s, "heartbeat to " + m_address);
  return fromProto(resp);
}

Status GrpcRegistryClient::reportJobExit(const JobExitReport& report) {
  mv1::ReportJobExitRequest req;
  toProto(report, &req);
  mv1::ReportJobExitResponse resp;
  auto ctx = rpc::contextWithDeadline(m_reportDeadline);
  return rpc::fromGrpc(m_stub->ReportJobExit(ctx.get(), req, &resp), "ReportJobExit to " + m_address);
}

}  // namespace pflow::agent
