// The manager's domain types: devices, nodes, jobs, leases. Plain C++ (no protobuf, no gRPC): the adapters in
// ManagerService.cc and the gRPC clients convert to and from the wire types. Times are Unix seconds (doubles).
#pragma once
#include <compare>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace pflow::manager {

// ---- devices and nodes -------------------------------------------------------------------------------------------

enum class DeviceKind { kGpu, kCpu };
const char* deviceKindName(DeviceKind kind);  // "GPU", "CPU"

// A device a job can run on: a GPU of a node (CUDA ordinal) or a CPU slot of a node without GPUs.
struct DeviceKey {
  std::string node;
  int index = 0;
  DeviceKind kind = DeviceKind::kGpu;
  auto operator<=>(const DeviceKey&) const = default;
  std::string toString() const;  // "node-a/GPU 1"
};

// What an agent reports about a device in its heartbeat.
struct DeviceInfo {
  DeviceKey key;
  std::string name;  // "NVIDIA H100 80GB HBM3", "CPU slot (16 cores)"
  std::uint64_t memoryTotalBytes = 0;
  std::uint64_t memoryUsedBytes = 0;
  double utilization = 0;    // 0..1
  double temperatureC = 0;   // 0 = unknown
};

enum class DeviceState { kFree, kBusy, kLost };
const char* deviceStateName(DeviceState state);

struct DeviceView {
  DeviceInfo info;
  DeviceState state = DeviceState::kFree;
  std::string jobId;  // when busy
};

struct NodeView {
  std::string name;
  std::string agentAddress;
  bool lost = false;
  double lastHeartbeat = 0;
  std::vector<DeviceView> devices;
  // Placement through Slurm (agentAddress "slurm"): the node's state and reason as Slurm reports them, its load.
  std::string slurmState;
  std::string slurmReason;
  std::vector<std::string> slurmPartitions;
  double cpuLoad = -1;  // -1 = unknown
};

// ---- jobs --------------------------------------------------------------------------------------------------------

// kRequeued: back in the queue after a failure of its node or worker that a new attempt may not repeat (Manager).
// kBuilding: submitted, its scene being built by the frontend (SubmitJob answers at once; the job then goes QUEUED
// or FAILED with the scene's errors or the reason it was refused).
enum class JobState { kQueued, kStarting, kRunning, kSucceeded, kFailed, kCancelling, kCancelled, kRequeued, kBuilding };
const char* jobStateName(JobState state);  // "QUEUED", ...
std::optional<JobState> jobStateFromName(const std::string& name);
bool isFinal(JobState state);         // succeeded, failed, cancelled
bool isWaiting(JobState state);       // queued, requeued: in the queue
bool holdsDevices(JobState state);    // starting, running, cancelling: the job has a lease

// What a scene asks of Slurm (its slurm: section; frontend/SceneLoader.h), carried to the job.
struct SlurmRequest {
  std::string partition;
  std::string account;
  std::string timeLimit;
};

struct Progress {
  std::int64_t step = 0;
  std::int64_t totalSteps = 0;
  double time = 0;                    // simulated, s
  double duration = 0;                // simulated, s
  double particleStepsPerSecond = 0;
  double etaSeconds = 0;              // wall clock, s
};

struct Job {
  std::int64_t seq = 0;               // submission order (FIFO); the id is derived from it
  std::string id;
  std::string name;
  JobState state = JobState::kQueued;
  std::string reason;                 // why it failed or was cancelled
  std::string sceneName;              // scene reference: the file name, the built model's id and URI
  std::string modelId;
  std::string modelUri;
  std::uint64_t particles = 0;
  double memoryBytes = 0;             // the frontend's estimate for the whole model on one device (0 = unknown)
  int maxDevices = 0;                 // 0 = as many as the particle count deserves
  bool wait = true;
  std::vector<DeviceKey> devices;     // rank order; kept after the job ends (the lease is released then)
  double submittedAt = 0;
  double startedAt = 0;               // when it left the queue (0 = never)
  double finishedAt = 0;              // when it reached a final state (0 = not yet)
  Progress progress;
  double progressAt = 0;              // wall time of the last progress report
  std::string message;                // the last progress message from the worker
  int exitCode = 0;
  std::string model;                  // the least model chosen for the scene (BuiltModel::model)
  int attempts = 0;                   // how many times it was started (the current attempt's number once started)
  int maxAttempts = 0;                // the manager's --max-attempts when it was submitted (0: the manager's now)
  std::string owner;                  // the user who submitted it ("" for jobs from before users existed: admins only)
  std::string slurmJobId;             // placement through Slurm: the Slurm job of its current attempt ("" = none yet)
  SlurmRequest slurm;                 // the scene's partition, account and time limit ("": the manager's defaults)
};

// The user a ManagerService call comes from (by its bearer token; docs/security.md): the adapter establishes it,
// the Manager decides what it may do. Nodes are checked by certificate in NodeRegistry, not through this.
struct Principal {
  std::string name;
  bool admin = false;  // may see and touch every job, and manage users
  static Principal user(std::string name, bool admin = false) { return {std::move(name), admin}; }
  // May see and touch `job`: its owner or an admin.
  bool mayAccess(const Job& job) const { return admin || job.owner == name; }
};

// What a job may use, as sent to the agent of its first device's node.
struct Lease {
  std::string jobId;
  std::string modelUri;
  std::vector<DeviceKey> devices;                 // one rank per device, in rank order
  std::map<std::string, std::string> nodeHosts;   // node -> host, for a hostfile
  std::string managerAddress;
  std::string backendAddress;
  int attempt = 1;  // the job's attempts: > 1 after a requeue (the worker resumes from its last checkpoint)
};

// ---- requests ----------------------------------------------------------------------------------------------------

struct AttachedFile {
  std::string path;
  std::string content;
};

struct SubmitRequest {
  std::string name;
  std::string sceneYaml;
  std::string sceneName;
  std::vector<AttachedFile> files;
  bool wait = false;
  int maxDevices = 0;
  std::string owner;  // the submitting user
};

// The frontend's answer to a build: where the model is and how big it is.
struct BuiltModel {
  std::string modelId;
  std::string modelUri;
  std::uint64_t particles = 0;
  double memoryBytes = 0;
  std::int64_t steps = 0;
  double duration = 0;  // simulated, s
  std::string model;    // the least model's decisions, one per line (pflow validate's "Model" section)
  SlurmRequest slurm;   // the scene's slurm: section
};

struct HeartbeatInfo {
  std::string node;
  std::string agentAddress;
  std::vector<DeviceInfo> devices;
  std::vector<std::string> runningJobs;
};

struct HeartbeatReply {
  double heartbeatIntervalSeconds = 2;
  std::vector<std::string> stopJobs;
};

struct JobEvent {
  Job job;
  std::string message;
};

}  // namespace pflow::manager
