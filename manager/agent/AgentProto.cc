#include "manager/agent/AgentProto.h"

namespace pflow::agent {

namespace cv1 = pflow::common::v1;
namespace mv1 = pflow::manager::v1;

void toProto(const DeviceInfo& d, const std::string& node, mv1::Device* out) {
  out->mutable_ref()->set_node(node);
  out->mutable_ref()->set_index(d.index);
  out->mutable_ref()->set_kind(d.kind == DeviceKind::kGpu ? cv1::DEVICE_KIND_GPU : cv1::DEVICE_KIND_CPU);
  out->set_name(d.name);
  out->set_memory_total_bytes(d.memoryTotalBytes);
  out->set_memory_used_bytes(d.memoryUsedBytes);
  out->set_utilization(d.utilization);
  out->set_temperature_c(d.temperatureC);
}

void toProto(const DeviceStatus& d, const std::string& node, mv1::Device* out) {
  toProto(d.info, node, out);
  out->set_state(d.jobId.empty() ? mv1::DEVICE_STATE_FREE : mv1::DEVICE_STATE_BUSY);
  out->set_job_id(d.jobId);
}

Result<Lease> fromProto(const pflow::agent::v1::Lease& in) {
  Lease lease;
  lease.jobId = in.job_id();
  lease.modelUri = in.model_uri();
  lease.managerAddress = in.manager_address();
  lease.backendAddress = in.backend_address();
  lease.attempt = in.attempt() > 0 ? in.attempt() : 1;
  lease.nodeHosts.insert(in.node_hosts().begin(), in.node_hosts().end());
  for (int i = 0; i < in.devices_size(); ++i) {
    const cv1::DeviceRef& d = in.devices(i);
    DeviceRef ref{d.node(), DeviceKind::kGpu, d.index()};
    switch (d.kind()) {
      case cv1::DEVICE_KIND_GPU: ref.kind = DeviceKind::kGpu; break;
      case cv1::DEVICE_KIND_CPU: ref.kind = DeviceKind::kCpu; break;
      default:
        return invalidArgument("lease.devices[" + std::to_string(i) + "].kind: unspecified or unknown (" +
                               std::to_string(static_cast<int>(d.kind())) + ")");
    }
    lease.devices.push_back(std::move(ref));
  }
  return lease;
}

void toProto(const HeartbeatPayload& p, mv1::HeartbeatRequest* out) {
  out->set_node(p.node);
  out->set_agent_address(p.agentAddress);
  for (const DeviceInfo& d : p.devices) toProto(d, p.node, out->add_devices());
  for (const std::string& j : p.runningJobs) out->add_running_jobs(j);
}

HeartbeatReply fromProto(const mv1::HeartbeatResponse& r) {
  HeartbeatReply reply;
  reply.intervalSeconds = r.heartbeat_interval_seconds();
  reply.stopJobs.assign(r.stop_jobs().begin(), r.stop_jobs().end());
  return reply;
}

void toProto(const JobExitReport& r, mv1::ReportJobExitRequest* out) {
  out->set_job_id(r.jobId);
  out->set_node(r.node);
  out->set_exit_code(r.exitCode);
  out->set_reason(r.reason);
}

}  // namespace pflow::agent
