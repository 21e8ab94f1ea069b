// The SnapshotService gRPC adapter on the callback API: translates proto <-> domain and calls SnapshotStore.
//  * WriteSnapshot: SnapshotIngest (ServerReadReactor): each chunk is appended on the executor, then the next read
//    starts; the client's half-close commits; a cancelled or failed stream aborts (no partial snapshot).
//  * ReadSnapshot: SnapshotStreamer (ServerWriteReactor): reads the next chunk (<= 1 MiB, on the executor) only
//    after the previous write completed, so a stream holds one chunk in memory whatever the snapshot's size.
//  * ListSnapshots, AppendProbes: unary (DefaultReactor), the store's work on the executor.
//  * WriteCheckpoint, ReadCheckpoint: the same two stream shapes over the store's CheckpointStore
//    (CheckpointStreams.cc): one chunk in memory at a time, file work on the executor.
// Reactions never block: HDF5 work runs on a small executor owned by the service (which must outlive the server).
//
// Who calls (docs/security.md): writes (snapshots, probes, checkpoints) and checkpoint reads come from nodes (their
// workers' certificates); snapshot reads from nodes or from users whose token the manager accepts for the job
// (JobAccess, asked on the executor). Without TLS nothing is verified (--insecure binds to loopback only).
#pragma once
#include <grpcpp/grpcpp.h>

#include <memory>

#include "common/TaskPool.h"

#include "backend/JobAccess.h"
#include "backend/SnapshotStore.h"
#include "pflow/backend/v1/snapshot_service.grpc.pb.h"

namespace pflow::backend {


class SnapshotService final : public v1::SnapshotService::CallbackService {
 public:
  // `access`: how user reads are checked (may be null only without TLS); not owned.
  explicit SnapshotService(SnapshotStore& store, int workers = 2, JobAccess* access = nullptr);
  ~SnapshotService() override;

  grpc::ServerReadReactor<v1::SnapshotChunk>* WriteSnapshot(grpc::CallbackServerContext* context,
                                                           v1::WriteSnapshotResponse* response) override;
  grpc::ServerUnaryReactor* ListSnapshots(grpc::CallbackServerContext* context, const v1::ListSnapshotsRequest* request,
                                          v1::ListSnapshotsResponse* response) override;
  grpc::ServerWriteReactor<v1::SnapshotChunk>* ReadSnapshot(grpc::CallbackServerContext* context,
                                                           const v1::ReadSnapshotRequest* request) override;
  grpc::ServerUnaryReactor* AppendProbes(grpc::CallbackServerContext* context, const v1::AppendProbesRequest* request,
                                         v1::AppendProbesResponse* response) override;
  grpc::ServerReadReactor<v1::CheckpointChunk>* WriteCheckpoint(grpc::CallbackServerContext* context,
                                                               v1::WriteCheckpointResponse* response) override;
  grpc::ServerWriteReactor<v1::CheckpointChunk>* ReadCheckpoint(grpc::CallbackServerContext* context,
                                                               const v1::ReadCheckpointRequest* request) override;
  grpc::ServerUnaryReactor* DeleteJobData(grpc::CallbackServerContext* context, const v1::DeleteJobDataRequest* request,
                                          v1::DeleteJobDataResponse* response) override;

 private:
  // Who may read job `jobId`: a node, or a user the manager lets read it. Blocking (JobAccess): on the executor.
  Status mayRead(const std::string& peer, const std::string& token, const std::string& jobId) const;
  SnapshotStore& m_store;
  std::unique_ptr<TaskPool> m_executor;
  JobAccess* m_access;
};

// CheckpointStreams.cc: the reactors of WriteCheckpoint and ReadCheckpoint.
grpc::ServerReadReactor<v1::CheckpointChunk>* newCheckpointUpload(CheckpointStore& store, TaskPool& executor,
                                                                  grpc::CallbackServerContext* context,
                                                                  v1::WriteCheckpointResponse* response);
grpc::ServerWriteReactor<v1::CheckpointChunk>* newCheckpointDownload(CheckpointStore& store, TaskPool& executor,
                                                                     const v1::ReadCheckpointRequest& request);

}  // namespace pflow::backend
