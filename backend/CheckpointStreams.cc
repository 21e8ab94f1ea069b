// The WriteCheckpoint and ReadCheckpoint reactors (SnapshotService.h): a checkpoint's bytes in chunks of at most
// 1 MiB, one chunk in memory at a time, the file work on the service's executor.
#include <spdlog/spdlog.h>

#include <atomic>
#include <cstdio>
#include <vector>

#include "backend/SnapshotService.h"
#include "common/rpc/Rpc.h"

namespace pflow::backend {

namespace {

constexpr std::size_t kChunkBytes = std::size_t(1) << 20;

// WriteCheckpoint: chunk by chunk into the store's upload; the half-close commits it.
class CheckpointUpload final : public grpc::ServerReadReactor<v1::CheckpointChunk> {
 public:
  CheckpointUpload(CheckpointStore& store, TaskPool& executor, grpc::CallbackServerContext* context, v1::WriteCheckpointResponse* response)
      : m_store(store), m_executor(executor), m_context(context), m_response(response) {
    StartRead(&m_chunk);
  }
  void OnReadDone(bool ok) override {
    if (ok) m_executor.post([this] { append(); });
    else m_executor.post([this] { commit(); });
  }
  void OnCancel() override { m_cancelled = true; }
  void OnDone() override { delete this; }

 private:
  void append() {
    if (m_cancelled) return finish({StatusCode::kCancelled, "cancelled"});
    if (m_chunk.data().size() > kChunkBytes)
      return finish(invalidArgument("a checkpoint chunk of " + std::to_string(m_chunk.data().size()) + " bytes (at most 1 MiB)"));
    if (!m_upload) {
      auto u = m_store.begin(m_chunk.job_id(), m_chunk.step(), m_chunk.total_bytes());
      if (!u) return finish(u.status());
      m_upload = std::move(u).value();
      m_jobId = m_chunk.job_id();
      m_step = m_chunk.step();
      m_total = m_chunk.total_bytes();
    } else if (m_chunk.job_id() != m_jobId || m_chunk.step() != m_step || m_chunk.total_bytes() != m_total) {
      return finish(invalidArgument("checkpoint chunks of one stream must repeat its job, step and total_bytes"));
    }
    if (Status st = m_upload->append(m_chunk.offset(), m_chunk.data().data(), m_chunk.data().size()); !st) return finish(st);
    StartRead(&m_chunk);
  }
  void commit() {
    if (m_cancelled || m_context->IsCancelled()) return finish({StatusCode::kCancelled, "stream cancelled"});
    if (!m_upload) return finish(invalidArgument("the stream held no chunks"));
    auto stored = m_upload->commit();
    if (!stored) return finish(stored.status());
    m_response->set_job_id(m_jobId);
    m_response->set_step(stored->step);
    m_response->set_bytes(stored->bytes);
    finish(Status::ok());
  }
  void finish(const Status& st) {
    m_upload.reset();  // removes an upload never committed
    if (!st && st.code() != StatusCode::kCancelled) spdlog::warn("WriteCheckpoint: {}", st.toString());
    Finish(rpc::toGrpc(st));
  }

  CheckpointStore& m_store;
  TaskPool& m_executor;
  grpc::CallbackServerContext* m_context;
  v1::WriteCheckpointResponse* m_response;
  v1::CheckpointChunk m_chunk;
  std::unique_ptr<CheckpointStore::Upload> m_upload;
  std::string m_jobId;
  std::int64_t m_step = 0;
  std::uint64_t m_total = 0;
  std::atomic<bool> m_cancelled{false};
};

// ReadCheckpoint: the latest checkpoint's file opened once (a commit that replaces it meanwhile does not cut the
// stream), read one chunk at a time after the previous write completed.
class CheckpointDownload final : public grpc::ServerWriteReactor<v1::CheckpointChunk> {
 public:
  CheckpointDownload(CheckpointStore& store, TaskPool& executor, const v1::ReadCheckpointRequest& request)
      : m_store(store), m_executor(executor), m_jobId(request.job_id()) {
    m_executor.post([this] { open(); });
  }
  ~CheckpointDownload() override {
    if (m_file) std::fclose(m_file);
  }
  void OnWriteDone(bool ok) override {
    if (!ok) return finish({StatusCode::kCancelled, "the client went away"});
    m_executor.post([this] { produce(); });
  }
  void OnCancel() override { m_cancelled = true; }
  void OnDone() override { delete this; }

 private:
  void open() {
    auto latest = m_store.latest(m_jobId);
    if (!latest) return finish(latest.status());
    m_stored = latest.value();
    m_file = std::fopen(m_stored.path.c_str(), "rb");
    if (!m_file) return finish(ioError("cannot open '" + m_stored.path + "'"));
    m_buffer.resize(kChunkBytes);
    produce();
  }
  void produce() {
    if (m_cancelled) return finish({StatusCode::kCancelled, "cancelled"});
    if (m_offset >= m_stored.bytes && m_offset > 0) return finish(Status::ok());
    const std::size_t want = std::size_t(std::min<std::uint64_t>(kChunkBytes, m_stored.bytes - m_offset));
    if (want > 0 && std::fread(m_buffer.data(), 1, want, m_file) != want) return finish(ioError("cannot read '" + m_stored.path + "'"));
    m_message.Clear();
    m_message.set_job_id(m_jobId);
    m_message.set_step(m_stored.step);
    m_message.set_total_bytes(m_stored.bytes);
    m_message.set_offset(m_offset);
    m_message.set_data(m_buffer.data(), want);
    m_offset += want;
    if (want == 0) m_offset = 1;  // an empty file: one empty chunk, then the end
    StartWrite(&m_message);
  }
  void finish(const Status& st) {
    if (!st && st.code() != StatusCode::kCancelled && st.code() != StatusCode::kNotFound) spdlog::warn("ReadCheckpoint: {}", st.toString());
    Finish(rpc::toGrpc(st));
  }

  CheckpointStore& m_store;
  TaskPool& m_executor;
  std::string m_jobId;
  StoredCheckpoint m_stored;
  std::FILE* m_file = nullptr;
  std::vector<char> m_buffer;
  std::uint64_t m_offset = 0;
  v1::CheckpointChunk m_message;
  std::atomic<bool> m_cancelled{false};
};

}  // namespace

grpc::ServerReadReactor<v1::CheckpointChunk>* newCheckpointUpload(CheckpointStore& store, TaskPool& executor,
                                                                  grpc::CallbackServerContext* context,
                                                                  v1::WriteCheckpointResponse* response) {
  return new CheckpointUpload(store, executor, context, response);
}

grpc::ServerWriteReactor<v1::CheckpointChunk>* newCheckpointDownload(CheckpointStore& store, TaskPool& executor,
                                                                     const v1::ReadCheckpointRequest& request) {
  return new CheckpointDownload(store, executor, request);
}

}  // namespace pflow::backend
