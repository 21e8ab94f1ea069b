#include "manager/ProtoConvert.h"

namespace pflow::manager {

namespace cv1 = pflow::common::v1;
namespace mv1 = pflow::manager::v1;

cv1::DeviceRef toProto(const DeviceKey& key) {
  cv1::DeviceRef r;
  r.set_node(key.node);
  r.set_index(key.index);
  r.set_kind(key.kind == DeviceKind::kGpu ? cv1::DEVICE_KIND_GPU : cv1::DEVICE_KIND_CPU);
  return r;
}

mv1::JobState toProto(JobState state) {
  switch (state) {
    case JobState::kQueued: return mv1::JOB_STATE_QUEUED;
    case JobState::kStarting: return mv1::JOB_STATE_STARTING;
    case JobState::kRunning: return mv1::JOB_STATE_RUNNING;
    case JobState::kSucceeded: return mv1::JOB_STATE_SUCCEEDED;
    case JobState::kFailed: return mv1::JOB_STATE_FAILED;
    case JobState::kCancelling: return mv1::JOB_STATE_CANCELLING;
    case JobState::kCancelled: return mv1::JOB_STATE_CANCELLED;
    case JobState::kRequeued: return mv1::JOB_STATE_REQUEUED;
    case JobState::kBuilding: return mv1::JOB_STATE_BUILDING;
  }
  return mv1::JOB_STATE_UNSPECIFIED;
}

mv1::Job toProto(const Job& j) {
  mv1::Job p;
  p.set_id(j.id);
  p.set_name(j.name);
  p.set_state(toProto(j.state));
  p.set_reason(j.reason);
  p.set_particles(j.particles);
  for (const DeviceKey& d : j.devices) *p.add_devices() = toProto(d);
  p.set_model_uri(j.modelUri);
  p.set_submitted_at(j.submittedAt);
  p.set_started_at(j.startedAt);
  p.set_finished_at(j.finishedAt);
  auto* pr = p.mutable_progress();
  pr->set_step(j.progress.step);
  pr->set_total_steps(j.progress.totalSteps);
  pr->set_time(j.progress.time);
  pr->set_duration(j.progress.duration);
  pr->set_particle_steps_per_second(j.progress.particleStepsPerSecond);
  pr->set_eta_seconds(j.progress.etaSeconds);
  p.set_exit_code(j.exitCode);
  p.set_model(j.model);
  p.set_attempts(j.attempts);
  p.set_max_attempts(j.maxAttempts);
  p.set_owner(j.owner);
  p.set_slurm_job_id(j.slurmJobId);
  return p;
}

mv1::Node toProto(const NodeView& n) {
  mv1::Node p;
  p.set_name(n.name);
  p.set_agent_address(n.agentAddress);
  p.set_lost(n.lost);
  p.set_last_heartbeat(n.lastHeartbeat);
  p.set_slurm_state(n.slurmState);
  p.set_slurm_reason(n.slurmReason);
  p.set_cpu_load(n.cpuLoad);
  for (const DeviceView& d : n.devices) {
    auto* pd = p.add_devices();
    *pd->mutable_ref() = toProto(d.info.key);
    pd->set_name(d.info.name);
    pd->set_state(d.state == DeviceState::kFree   ? mv1::DEVICE_STATE_FREE
                  : d.state == DeviceState::kBusy ? mv1::DEVICE_STATE_BUSY
                                                  : mv1::DEVICE_STATE_LOST);
    pd->set_job_id(d.jobId);
    pd->set_memory_total_bytes(d.info.memoryTotalBytes);
    pd->set_memory_used_bytes(d.info.memoryUsedBytes);
    pd->set_utilization(d.info.utilization);
    pd->set_temperature_c(d.info.temperatureC);
  }
  return p;
}

pflow::agent::v1::Lease toProto(const Lease& l) {
  pflow::agent::v1::Lease p;
  p.set_job_id(l.jobId);
  p.set_model_uri(l.modelUri);
  for (const DeviceKey& d : l.devices) *p.add_devices() = toProto(d);
  for (const auto& [node, host] : l.nodeHosts) (*p.mutable_node_hosts())[node] = host;
  p.set_manager_address(l.managerAddress);
  p.set_backend_address(l.backendAddress);
  p.set_attempt(l.attempt);
  return p;
}

Progress fromProto(const mv1::Progress& p) {
  Progress q;
  q.step = p.step();
  q.totalSteps = p.total_steps();
  q.time = p.time();
  q.duration = p.duration();
  q.particleStepsPerSecond = p.particle_steps_per_second();
  q.etaSeconds = p.eta_seconds();
  return q;
}

SubmitRequest fromProto(const mv1::SubmitJobRequest& r) {
  SubmitRequest s;
  s.name = r.name();
  s.sceneYaml = r.scene_yaml();
  s.sceneName = r.scene_name();
  for (const auto& f : r.files()) s.files.push_back({f.path(), f.content()});
  s.wait = r.wait();
  s.maxDevices = r.max_devices();
  return s;
}

Result<HeartbeatInfo> fromProto(const mv1::HeartbeatRequest& r) {
  HeartbeatInfo hb;
  hb.node = r.node();
  hb.agentAddress = r.agent_address();
  ErrorList errors;
  for (int i = 0; i < r.devices_size(); ++i) {
    const auto& d = r.devices(i);
    DeviceInfo info;
    info.key.node = d.ref().node().empty() ? r.node() : d.ref().node();  // the node may be left implicit
    info.key.index = d.ref().index();
    if (d.ref().kind() == cv1::DEVICE_KIND_GPU) {
      info.key.kind = DeviceKind::kGpu;
    } else if (d.ref().kind() == cv1::DEVICE_KIND_CPU) {
      info.key.kind = DeviceKind::kCpu;
    } else {
      errors.add("devices[" + std::to_string(i) + "].ref.kind", "is unspecified: say GPU or CPU");
    }
    info.name = d.name();
    info.memoryTotalBytes = d.memory_total_bytes();
    info.memoryUsedBytes = d.memory_used_bytes();
    info.utilization = d.utilization();
    info.temperatureC = d.temperature_c();
    hb.devices.push_back(std::move(info));
  }
  if (!errors.empty()) return errors.toStatus("heartbeat");
  hb.runningJobs.assign(r.running_jobs().begin(), r.running_jobs().end());
  return hb;
}

}  // namespace pflow::manager
