// SnapshotService adapter. See SnapshotService.h.
#include "backend/SnapshotService.h"
#include "common/Log.h"

#include <spdlog/spdlog.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "backend/ChunkProto.h"
#include "common/rpc/Rpc.h"

namespace pflow::backend {

namespace {

// WriteSnapshot. Exactly one operation is outstanding at a time (a read, or a task on the executor), so Finish is
// called once, by whichever completes last; OnDone deletes the reactor.
class SnapshotIngest final : public grpc::ServerReadReactor<v1::SnapshotChunk> {
 public:
  SnapshotIngest(SnapshotStore& store, TaskPool& executor, grpc::CallbackServerContext* context,
                 v1::WriteSnapshotResponse* response)
      : m_store(store), m_executor(executor), m_context(context), m_response(response) {
    StartRead(&m_chunk);
  }

  void OnReadDone(bool ok) override {
    if (ok) {
      m_executor.post([this] { append(); });
    } else {
      m_executor.post([this] { commit(); });  // half-close (or a broken stream: see commit)
    }
  }
  void OnCancel() override { m_cancelled = true; }
  void OnDone() override { delete this; }

 private:
  void append() {
    if (m_cancelled) return finish({StatusCode::kCancelled, "cancelled"});
    auto chunk = chunkFromProto(std::move(m_chunk));
    if (!chunk) return finish(chunk.status());
    if (!m_ingest) {
      auto ingest = m_store.beginSnapshot(chunk->jobId, chunk->step, chunk->time, chunk->particles);
      if (!ingest) return finish(ingest.status());
      m_ingest = std::move(ingest.value());
    }
    if (Status st = m_ingest->appendChunk(chunk.value()); !st) return finish(st);
    StartRead(&m_chunk);
  }

  void commit() {
    // A broken stream also ends reads with !ok; it is cancelled by the time this task runs.
    if (m_cancelled || m_context->IsCancelled()) return finish({StatusCode::kCancelled, "stream cancelled"});
    if (!m_ingest) return finish(invalidArgument("the stream held no chunks"));
    auto result = m_ingest->commit();
    if (!result) return finish(result.status());
    m_response->set_job_id(result->jobId);
    m_response->set_step(result->step);
    m_response->set_bytes(result->bytes);
    spdlog::info("job '{}' step {}: stored {} bytes{}", result->jobId, result->step, result->bytes,
                 result->grid ? " with grid fields" : "");
    finish(Status::ok());
  }

  void finish(const Status& st) {
    if (m_ingest) m_ingest->abort();  // no-op after a commit
    m_ingest.reset();
    if (!st && st.code() != StatusCode::kCancelled) spdlog::warn("WriteSnapshot: {}", st.toString());
    Finish(rpc::toGrpc(st));  // the last thing: OnDone may run at once
  }

  SnapshotStore& m_store;
  TaskPool& m_executor;
  grpc::CallbackServerContext* m_context;
  v1::WriteSnapshotResponse* m_response;
  v1::SnapshotChunk m_chunk;
  std::unique_ptr<SnapshotStore::Ingest> m_ingest;
  std::atomic<bool> m_cancelled{false};
};

// ReadSnapshot: open on the executor, then alternately read one chunk (executor) and write it (gRPC).
class SnapshotStreamer final : public grpc::ServerWriteReactor<v1::SnapshotChunk> {
 public:
  // `authorize` runs first, on the executor: a failure ends the stream with it.
  SnapshotStreamer(SnapshotStore& store, TaskPool& executor, const v1::ReadSnapshotRequest& request, std::function<Status()> authorize,
                   std::string client)
      : m_store(store), m_executor(executor), m_authorize(std::move(authorize)), m_client(std::move(client)) {
    m_request.step = request.which_case() == v1::ReadSnapshotRequest::kStep ? std::optional(request.step())
                                                                             : std::nullopt;  // last
    m_request.fields.assign(request.fields().begin(), request.fields().end());
    m_request.includeGrid = request.include_grid();
    m_request.includeGeometry = request.include_geometry();
    m_request.includeProbes = request.include_probes();
    m_request.particles = !request.skip_particles();
    m_jobId = request.job_id();
    m_executor.post([this] { open(); });
  }

  void OnWriteDone(bool ok) override {
    if (!ok) return finish({StatusCode::kCancelled, "the client went away"});
    m_executor.post([this] { produce(); });
  }
  void OnCancel() override { m_cancelled = true; }
  void OnDone() override { delete this; }

 private:
  void open() {
    if (Status allowed = m_authorize(); !allowed) return finish(allowed);
    auto cursor = m_store.openRead(m_jobId, m_request);
    if (!cursor) return finish(cursor.status());
    m_cursor = std::move(cursor.value());
    produce();
  }

  void produce() {
    if (m_cancelled) return finish({StatusCode::kCancelled, "cancelled"});
    auto chunk = m_cursor->next();
    if (!chunk) return finish(chunk.status());
    if (!chunk->has_value()) return finish(Status::ok());
    chunkToProto(std::move(**chunk), &m_message);
    StartWrite(&m_message);
  }

  void finish(const Status& st) {
    if (!st && st.code() != StatusCode::kCancelled) {
      // Any user may ask: one of them asking in a loop must not fill the log.
      static log::RateLimit limit;
      std::uint64_t leftOut = 0;
      if (limit.allow(m_client, &leftOut))
        spdlog::warn("ReadSnapshot from {}: {}{}", m_client, log::escaped(st.toString(), 300),
                     leftOut ? " (" + std::to_string(leftOut) + " earlier lines from it left out)" : "");
    }
    m_cursor.reset();
    Finish(rpc::toGrpc(st));
  }

  SnapshotStore& m_store;
  TaskPool& m_executor;
  std::function<Status()> m_authorize;
  std::string m_client;
  std::string m_jobId;
  ReadRequest m_request;
  std::unique_ptr<SnapshotCursor> m_cursor;
  v1::SnapshotChunk m_message;
  std::atomic<bool> m_cancelled{false};
};

}  // namespace

SnapshotService::SnapshotService(SnapshotStore& store, int workers, JobAccess* access)
    : m_store(store), m_executor(std::make_unique<TaskPool>(workers)), m_access(access) {}

Status SnapshotService::mayRead(const std::string& peer, const std::string& token, const std::string& jobId) const {
  if (rpc::defaultTransport().insecure || !rpc::nodeOfIdentity(peer).empty()) return Status::ok();
  if (!m_access) return unavailable("this back-end has no manager to check readers with (start it with --manager)");
  return m_access->mayRead(token, jobId);
}

SnapshotService::~SnapshotService() = default;

grpc::ServerReadReactor<v1::SnapshotChunk>* SnapshotService::WriteSnapshot(grpc::CallbackServerContext* context,
                                                                          v1::WriteSnapshotResponse* response) {
  if (Status who = rpc::requireNode(*context, "WriteSnapshot"); !who) return rpc::refuse<grpc::ServerReadReactor<v1::SnapshotChunk>>(rpc::toGrpc(who));
  return new SnapshotIngest(m_store, *m_executor, context, response);
}

grpc::ServerUnaryReactor* SnapshotService::ListSnapshots(grpc::CallbackServerContext* context,
                                                         const v1::ListSnapshotsRequest* request,
                                                         v1::ListSnapshotsResponse* response) {
  auto* reactor = context->DefaultReactor();
  m_executor->post([this, reactor, request, response, peer = rpc::peerIdentity(*context), token = rpc::bearerToken(*context)] {
    if (Status allowed = mayRead(peer, token, request->job_id()); !allowed) {
      reactor->Finish(rpc::toGrpc(allowed));
      return;
    }
    auto listing = m_store.list(request->job_id());
    if (!listing) {
      reactor->Finish(rpc::toGrpc(listing.status()));
      return;
    }
    response->set_file(listing->file);
    for (const auto& s : listing->snapshots) {
      auto* info = response->add_snapshots();
      info->set_step(s.step);
      info->set_time(s.time);
      info->set_particles(s.particles);
    }
    reactor->Finish(grpc::Status::OK);
  });
  return reactor;
}

grpc::ServerWriteReactor<v1::SnapshotChunk>* SnapshotService::ReadSnapshot(grpc::CallbackServerContext* context,
                                                                          const v1::ReadSnapshotRequest* request) {
  return new SnapshotStreamer(m_store, *m_executor, *request,
                              [this, peer = rpc::peerIdentity(*context), token = rpc::bearerToken(*context), job = request->job_id()] {
                                return mayRead(peer, token, job);
                              },
                              rpc::clientKey(*context));
}

grpc::ServerUnaryReactor* SnapshotService::AppendProbes(grpc::CallbackServerContext* context, const v1::AppendProbesRequest* request,
                                                        v1::AppendProbesResponse* response) {
  auto* reactor = context->DefaultReactor();
  if (Status who = rpc::requireNode(*context, "AppendProbes"); !who) {
    reactor->Finish(rpc::toGrpc(who));
    return reactor;
  }
  m_executor->post([this, context, reactor, request, response] {
    if (context->IsCancelled()) {  // the caller's deadline passed while the call waited for the executor
      reactor->Finish(grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "AppendProbes waited past its deadline"));
      return;
    }
    auto samples = probesFromProto(*request);
    if (!samples) {
      reactor->Finish(rpc::toGrpc(samples.status()));
      return;
    }
    auto stored = m_store.appendProbes(request->job_id(), samples.value());
    if (!stored) {
      spdlog::warn("AppendProbes: {}", stored.status().toString());
      reactor->Finish(rpc::toGrpc(stored.status()));
      return;
    }
    response->set_samples(stored.value());
    reactor->Finish(grpc::Status::OK);
  });
  return reactor;
}

grpc::ServerReadReactor<v1::CheckpointChunk>* SnapshotService::WriteCheckpoint(grpc::CallbackServerContext* context,
                                                                              v1::WriteCheckpointResponse* response) {
  if (Status who = rpc::requireNode(*context, "WriteCheckpoint"); !who) return rpc::refuse<grpc::ServerReadReactor<v1::CheckpointChunk>>(rpc::toGrpc(who));
  return newCheckpointUpload(m_store.checkpoints(), *m_executor, context, response);
}

grpc::ServerWriteReactor<v1::CheckpointChunk>* SnapshotService::ReadCheckpoint(grpc::CallbackServerContext* context,
                                                                              const v1::ReadCheckpointRequest* request) {
  if (Status who = rpc::requireNode(*context, "ReadCheckpoint"); !who) return rpc::refuse<grpc::ServerWriteReactor<v1::CheckpointChunk>>(rpc::toGrpc(who));
  return newCheckpointDownload(m_store.checkpoints(), *m_executor, *request);
}

grpc::ServerUnaryReactor* SnapshotService::DeleteJobData(grpc::CallbackServerContext* context, const v1::DeleteJobDataRequest* request,
                                                         v1::DeleteJobDataResponse*) {
  auto* reactor = context->DefaultReactor();
  if (Status who = rpc::requirePeer(*context, "DeleteJobData", rpc::kManagerIdentity); !who) {
    reactor->Finish(rpc::toGrpc(who));
    return reactor;
  }
  m_executor->post([this, reactor, request] {
    const Status s = m_store.removeJob(request->job_id());
    if (s) spdlog::info("deleted the data of job {}", request->job_id());
    reactor->Finish(rpc::toGrpc(s));
  });
  return reactor;
}

}  // namespace pflow::backend
