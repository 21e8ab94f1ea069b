// The only place that knows both the manager's domain types and the wire types (pflow.manager.v1, pflow.agent.v1,
// pflow.common.v1).
#pragma once
#include "common/Status.h"
#include "manager/Types.h"
#include "pflow/agent/v1/agent_service.pb.h"
#include "pflow/manager/v1/manager_service.pb.h"
#include "pflow/manager/v1/node_registry.pb.h"

namespace pflow::manager {

pflow::common::v1::DeviceRef toProto(const DeviceKey& key);
pflow::manager::v1::JobState toProto(JobState state);
pflow::manager::v1::Job toProto(const Job& job);
pflow::manager::v1::Node toProto(const NodeView& node);
pflow::agent::v1::Lease toProto(const Lease& lease);

Progress fromProto(const pflow::manager::v1::Progress& p);
SubmitRequest fromProto(const pflow::manager::v1::SubmitJobRequest& r);
// INVALID_ARGUMENT for a device without a kind (the rest is checked by the Manager).
Result<HeartbeatInfo> fromProto(const pflow::manager::v1::HeartbeatRequest& r);

}  // namespace pflow::manager
