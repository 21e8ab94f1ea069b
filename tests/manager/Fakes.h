// Fakes and builders for manager tests (Ray's fake_*_client / Mocker::GenNodeInfo style): no network.
#pragma once
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "manager/AgentClient.h"
#include "manager/FrontendClient.h"
#include "manager/JobDataClient.h"
#include "manager/Types.h"

namespace pflow::manager::testing {

// Records every call; answers with configurable results. `onStart` runs inside startJob (without the manager's
// lock), so a test can act while a job is STARTING.
class FakeAgentClient final : public AgentClient {
 public:
  struct Start {
    std::string address;
    Lease lease;
  };
  struct Stop {
    std::string address;
    std::string jobId;
  };

  Result<std::int64_t> startJob(const std::string& address, const Lease& lease) override {
    std::function<void(const Lease&)> hook;
    std::optional<Status> error;
    std::int64_t pid = 0;
    {
      std::lock_guard lock(m_mu);
      starts.push_back({address, lease});
      pid = 1000 + static_cast<std::int64_t>(starts.size());
      hook = onStart;
      error = startError;
    }
    if (hook) hook(lease);
    if (error) return *error;
    return pid;
  }
  Status stopJob(const std::string& address, const std::string& jobId) override {
    std::lock_guard lock(m_mu);
    stops.push_back({address, jobId});
    return stopStatus;
  }
  std::vector<Start> startsCopy() const {
    std::lock_guard lock(m_mu);
    return starts;
  }
  std::vector<Stop> stopsCopy() const {
    std::lock_guard lock(m_mu);
    return stops;
  }

  std::vector<Start> starts;
  std::vector<Stop> stops;
  std::optional<Status> startError;
  Status stopStatus;
  std::function<void(const Lease&)> onStart;

 private:
  mutable std::mutex m_mu;
};

// Builds "models" without a frontend: the particle count comes from a line "particles: N" in the scene text
// (default 100000), the memory estimate from "memory: BYTES"; "invalid" in the text makes the scene invalid.
class FakeFrontendClient final : public FrontendClient {
 public:
  Result<BuiltModel> buildScene(const std::string& yaml, const std::string& name, const std::vector<AttachedFile>&) override {
    if (buildSeconds > 0) std::this_thread::sleep_for(std::chrono::duration<double>(buildSeconds));  // a slow build
    std::lock_guard lock(m_mu);
    if (unavailableError) return *unavailableError;
    if (yaml.find("invalid") != std::string::npos)
      return invalidArgument("scene '" + name + "' is invalid: 1 error(s)\nmaterials[0].density: must be positive");
    ++builds;
    BuiltModel m;
    m.modelId = "model-" + std::to_string(builds);
    m.modelUri = "/models/" + m.modelId;
    m.particles = 100000;
    m.steps = 1000;
    m.duration = 1.0;
    m.model = "  tangential history: off — every material and pair has friction 0\n";
    if (auto at = yaml.find("particles:"); at != std::string::npos) {
      unsigned long long n = 0;
      std::sscanf(yaml.c_str() + at, "particles: %llu", &n);
      m.particles = n;
    }
    if (auto at = yaml.find("memory:"); at != std::string::npos) std::sscanf(yaml.c_str() + at, "memory: %lf", &m.memoryBytes);
    return m;
  }
  int builds = 0;
  std::optional<Status> unavailableError;
  std::atomic<double> buildSeconds{0};

 private:
  std::mutex m_mu;
};

// Deletes nothing, records what it was asked; `error` makes it fail.
class FakeJobDataClient final : public JobDataClient {
 public:
  Status deleteJobData(const std::string& jobId) override {
    std::lock_guard lock(m_mu);
    deleted.push_back(jobId);
    return error ? *error : Status::ok();
  }
  std::vector<std::string> deleted;
  std::optional<Status> error;

 private:
  std::mutex m_mu;
};

inline std::string scene(unsigned long long particles) { return "particles: " + std::to_string(particles) + "\n"; }

// A heartbeat from `node` with `gpus` GPUs and `cpus` CPU slots (memory per device in bytes).
inline HeartbeatInfo nodeBeat(const std::string& node, int gpus, int cpus = 0, std::uint64_t memory = 80ull << 30,
                              std::vector<std::string> running = {}) {
  HeartbeatInfo hb;
  hb.node = node;
  hb.agentAddress = node + ":7000";
  auto add = [&](int index, DeviceKind kind) {
    DeviceInfo d;
    d.key.node = node;
    d.key.index = index;
    d.key.kind = kind;
    d.name = kind == DeviceKind::kGpu ? "NVIDIA H100" : "CPU slot";
    d.memoryTotalBytes = memory;
    hb.devices.push_back(std::move(d));
  };
  for (int i = 0; i < gpus; ++i) add(i, DeviceKind::kGpu);
  for (int i = 0; i < cpus; ++i) add(i, DeviceKind::kCpu);
  hb.runningJobs = std::move(running);
  return hb;
}

inline SubmitRequest submitRequest(unsigned long long particles, bool wait = false, int maxDevices = 0) {
  SubmitRequest r;
  r.name = "test";
  r.sceneYaml = scene(particles);
  r.sceneName = "test.yaml";
  r.wait = wait;
  r.maxDevices = maxDevices;
  return r;
}

}  // namespace pflow::manager::testing
