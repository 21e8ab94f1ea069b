// Conversions between the agent's domain types and pflow.agent.v1 / pflow.manager.v1 messages. Service code only.
#pragma once
#include "manager/agent/Agent.h"
#include "pflow/agent/v1/agent_service.pb.h"
#include "pflow/manager/v1/node_registry.pb.h"

namespace pflow::agent {

void toProto(const DeviceInfo& d, const std::string& node, pflow::manager::v1::Device* out);
void toProto(const DeviceStatus& d, const std::string& node, pflow::manager::v1::Device* out);  // with state and job
// Unknown device kinds become an INVALID_ARGUMENT naming the device.
Result<Lease> fromProto(const pflow::agent::v1::Lease& lease);
void toProto(const HeartbeatPayload& p, pflow::manager::v1::HeartbeatRequest* out);
HeartbeatReply fromProto(const pflow::manager::v1::HeartbeatResponse& r);
void toProto(const JobExitReport& r, pflow::manager::v1::ReportJobExitRequest* out);

}  // namespace pflow::agent
