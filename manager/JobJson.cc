#include "manager/JobJson.h"

namespace pflow::manager {

namespace mv1 = pflow::manager::v1;
using nlohmann::json;

const char* stateName(mv1::JobState s) {
  switch (s) {
    case mv1::JOB_STATE_QUEUED: return "queued";
    case mv1::JOB_STATE_STARTING: return "starting";
    case mv1::JOB_STATE_RUNNING: return "running";
    case mv1::JOB_STATE_SUCCEEDED: return "succeeded";
    case mv1::JOB_STATE_FAILED: return "failed";
    case mv1::JOB_STATE_CANCELLING: return "cancelling";
    case mv1::JOB_STATE_CANCELLED: return "cancelled";
    case mv1::JOB_STATE_REQUEUED: return "requeued";
    case mv1::JOB_STATE_BUILDING: return "building";
    default: return "unknown";
  }
}

json toJson(const mv1::Job& j) {
  const auto& p = j.progress();
  json devices = json::array();
  for (const auto& d : j.devices())
    devices.push_back({{"node", d.node()}, {"index", d.index()}, {"kind", d.kind() == common::v1::DEVICE_KIND_GPU ? "gpu" : "cpu"}});
  return {{"id", j.id()},
          {"name", j.name()},
          {"owner", j.owner()},
          {"state", stateName(j.state())},
          {"reason", j.reason()},
          {"particles", j.particles()},
          {"devices", devices},
          {"model_uri", j.model_uri()},
          {"submitted_at", j.submitted_at()},
          {"started_at", j.started_at()},
          {"finished_at", j.finished_at()},
          {"exit_code", j.exit_code()},
          {"attempts", j.attempts()},
          {"max_attempts", j.max_attempts()},
          {"model", j.model()},
          {"slurm_job_id", j.slurm_job_id()},
          {"progress",
           {{"step", p.step()},
            {"total_steps", p.total_steps()},
            {"time_s", p.time()},
            {"duration_s", p.duration()},
            {"particle_steps_per_s", p.particle_steps_per_second()},
            {"eta_s", p.eta_seconds()}}}};
}

json toJson(const mv1::Node& n) {
  auto stateOf = [](mv1::DeviceState st) {
    return st == mv1::DEVICE_STATE_FREE ? "free" : st == mv1::DEVICE_STATE_BUSY ? "busy" : st == mv1::DEVICE_STATE_LOST ? "lost" : "?";
  };
  json devs = json::array();
  for (const auto& d : n.devices())
    devs.push_back({{"index", d.ref().index()}, {"kind", d.ref().kind() == common::v1::DEVICE_KIND_GPU ? "gpu" : "cpu"}, {"name", d.name()},
                    {"state", stateOf(d.state())}, {"job", d.job_id()}, {"memory_total_bytes", d.memory_total_bytes()},
                    {"memory_used_bytes", d.memory_used_bytes()}, {"utilization", d.utilization()}, {"temperature_c", d.temperature_c()}});
  json out = {{"node", n.name()}, {"agent", n.agent_address()}, {"lost", n.lost()}, {"last_heartbeat", n.last_heartbeat()}, {"devices", devs}};
  if (!n.slurm_state().empty()) {
    out["slurm_state"] = n.slurm_state();
    out["slurm_reason"] = n.slurm_reason();
    out["cpu_load"] = n.cpu_load();
  }
  return out;
}

json toJson(const mv1::JobEvent& e) { return {{"job", toJson(e.job())}, {"message", e.message()}}; }

}  // namespace pflow::manager
