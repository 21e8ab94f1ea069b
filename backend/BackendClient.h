// The back-end's client interface, used by the compute worker (writeSnapshot) and the CLI (list, fetch), with a
// gRPC implementation and an in-process one (LocalBackendClient: the same calls on a SnapshotStore, the fake for
// tests of the worker and the CLI). Every gRPC call has a deadline: control calls short, bulk calls long.
#pragma once
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "backend/SnapshotStore.h"
#include "common/Status.h"
#include "compute/particles/ParticleSnapshot.h"

namespace grpc {
class Channel;
}

namespace pflow::backend {

class BackendClient {
 public:
  virtual ~BackendClient() = default;
  // Sends one snapshot (and the job's geometry, if given) in chunks of <= 1 MiB. ALREADY_EXISTS if the step is
  // stored; INVALID_ARGUMENT for a snapshot that does not fit together.
  virtual Status writeSnapshot(const std::string& jobId, const compute::ParticleSnapshot& snapshot,
                               const compute::GeometrySnapshot* geometryOrNull) = 0;
  // Appends probe samples (the ones since the last call) to the job's series, in requests of <= 1 MiB.
  virtual Status appendProbes(const std::string& jobId, const ProbeSeries& samples) = 0;
  // The job's snapshots by step. NOT_FOUND for an unknown job.
  virtual Result<std::vector<SnapshotInfo>> list(const std::string& jobId) = 0;
  // Streams snapshot `step` (nullopt = the last) into a new local file `outputH5` (+ .xmf) in the store's layout,
  // chunk by chunk through a scratch file (never the whole snapshot in memory). fields empty = all. includeProbes:
  // the job's whole probe series too, as /probes and as CSV beside the file (probesCsvPathFor).
  virtual Status fetch(const std::string& jobId, std::optional<std::int64_t> step, const std::string& outputH5,
                       std::vector<std::string> fields, bool includeGrid, bool includeGeometry, bool includeProbes = false) = 0;
  // Sends the checkpoint file at `path` (of step `step`) in chunks of <= 1 MiB; the back-end keeps it and the one
  // before. INVALID_ARGUMENT when the back-end does not read it as a checkpoint of that step.
  virtual Status writeCheckpoint(const std::string& jobId, std::int64_t step, const std::string& path) = 0;
  // The job's latest checkpoint into a new local file `path`; returns its step. NOT_FOUND when it has none.
  virtual Result<std::int64_t> readCheckpoint(const std::string& jobId, const std::string& path) = 0;
};

struct BackendClientOptions {
  double controlDeadlineSeconds = 10;  // ListSnapshots
  double bulkDeadlineSeconds = 600;    // WriteSnapshot, ReadSnapshot
};

// Talks to a pflow-backend over gRPC.
std::unique_ptr<BackendClient> makeGrpcBackendClient(std::shared_ptr<grpc::Channel> channel,
                                                     BackendClientOptions options = {});
std::unique_ptr<BackendClient> makeGrpcBackendClient(const std::string& address, BackendClientOptions options = {});

// The same calls on a SnapshotStore in this process (no gRPC): the fake for worker and CLI tests.
class LocalBackendClient final : public BackendClient {
 public:
  explicit LocalBackendClient(SnapshotStore& store) : m_store(store) {}
  Status writeSnapshot(const std::string& jobId, const compute::ParticleSnapshot& snapshot,
                       const compute::GeometrySnapshot* geometryOrNull) override;
  Status appendProbes(const std::string& jobId, const ProbeSeries& samples) override;
  Result<std::vector<SnapshotInfo>> list(const std::string& jobId) override;
  Status fetch(const std::string& jobId, std::optional<std::int64_t> step, const std::string& outputH5,
               std::vector<std::string> fields, bool includeGrid, bool includeGeometry, bool includeProbes = false) override;
  Status writeCheckpoint(const std::string& jobId, std::int64_t step, const std::string& path) override;
  Result<std::int64_t> readCheckpoint(const std::string& jobId, const std::string& path) override;

 private:
  SnapshotStore& m_store;
};

}  // namespace pflow::backend
