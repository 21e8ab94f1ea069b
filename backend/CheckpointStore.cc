#include "backend/CheckpointStore.h"

#include <spdlog/spdlog.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "backend/SnapshotStore.h"
#include "backend/store/CheckpointFile.h"

namespace pflow::backend {

namespace fs = std::filesystem;

namespace {

constexpr const char* kIncoming = ".incoming";

std::string lastPath(const std::string& dir, const std::string& jobId) { return (fs::path(dir) / (jobId + ".h5")).string(); }

// An I/O error of the disk: RESOURCE_EXHAUSTED when it is full, IO otherwise.
Status diskError(const std::string& what, int err) {
  if (err == ENOSPC || err == EDQUOT) return Status(StatusCode::kResourceExhausted, what + ": the disk is full");
  return ioError(what + ": " + std::strerror(err));
}

}  // namespace

Result<std::unique_ptr<CheckpointStore>> CheckpointStore::open(CheckpointStoreOptions options) {
  if (options.dir.empty()) return invalidArgument("checkpoint directory is empty");
  std::error_code ec;
  const fs::path incoming = fs::path(options.dir) / kIncoming;
  fs::create_directories(incoming, ec);
  if (ec) return ioError(incoming.string() + ": cannot create: " + ec.message());
  std::size_t removed = 0;
  for (const auto& entry : fs::directory_iterator(incoming, ec)) {
    std::error_code rm;
    if (fs::remove(entry.path(), rm)) ++removed;
  }
  if (removed > 0) spdlog::info("removed {} unfinished checkpoint upload(s) in {}", removed, incoming.string());
  if (!options.freeBytes) options.freeBytes = fileSystemFreeBytes;
  return std::unique_ptr<CheckpointStore>(new CheckpointStore(std::move(options)));
}

std::mutex& CheckpointStore::jobMutex(const std::string& jobId) {
  std::lock_guard lock(m_mu);
  auto& m = m_jobMutex[jobId];
  if (!m) m = std::make_unique<std::mutex>();
  return *m;
}

Result<std::unique_ptr<CheckpointStore::Upload>> CheckpointStore::begin(const std::string& jobId, std::int64_t step, std::uint64_t totalBytes) {
  PFLOW_TRY(validateJobId(jobId));
  if (step < 0) return invalidArgument("checkpoint of job '" + jobId + "': step " + std::to_string(step) + " is negative");
  if (totalBytes == 0) return invalidArgument("checkpoint of job '" + jobId + "': total_bytes is 0");
  const std::uint64_t free = m_options.freeBytes(m_options.dir);
  if (free < totalBytes || free - totalBytes < m_options.reserveBytes)
    return Status(StatusCode::kResourceExhausted, "checkpoint of job '" + jobId + "' (" + std::to_string(totalBytes) + " bytes): " +
                                                      std::to_string(free) + " bytes free on the back-end's disk, " +
                                                      std::to_string(m_options.reserveBytes) + " kept in reserve");
  std::unique_ptr<Upload> u(new Upload());
  u->m_store = this;
  u->m_jobId = jobId;
  u->m_step = step;
  u->m_total = totalBytes;
  {
    std::lock_guard lock(m_mu);
    u->m_path = (fs::path(m_options.dir) / kIncoming / (jobId + "." + std::to_string(++m_serial) + ".h5")).string();
  }
  u->m_file = std::fopen(u->m_path.c_str(), "wb");
  if (!u->m_file) return diskError("cannot create '" + u->m_path + "'", errno);
  return u;
}

CheckpointStore::Upload::~Upload() {
  if (m_file) std::fclose(m_file);
  if (!m_done) {
    std::error_code ec;
    fs::remove(m_path, ec);
  }
}

Status CheckpointStore::Upload::append(std::uint64_t offset, const void* data, std::size_t size) {
  if (m_done || !m_file) return failedPrecondition("checkpoint upload of job '" + m_jobId + "' is closed");
  if (offset != m_written)
    return invalidArgument("checkpoint of job '" + m_jobId + "': a chunk at byte " + std::to_string(offset) + " where " +
                           std::to_string(m_written) + " was expected (chunks come in order)");
  if (size > m_total - m_written)
    return invalidArgument("checkpoint of job '" + m_jobId + "': chunks go past total_bytes " + std::to_string(m_total));
  if (size > 0 && std::fwrite(data, 1, size, m_file) != size) return diskError("cannot write '" + m_path + "'", errno);
  m_written += size;
  return Status::ok();
}

Result<StoredCheckpoint> CheckpointStore::Upload::commit() {
  if (m_done || !m_file) return failedPrecondition("checkpoint upload of job '" + m_jobId + "' is closed");
  if (m_written != m_total)
    return invalidArgument("checkpoint of job '" + m_jobId + "' is incomplete: " + std::to_string(m_written) + " of " +
                           std::to_string(m_total) + " bytes arrived");
  const bool flushed = std::fflush(m_file) == 0;
  const int err = errno;
  std::fclose(m_file);
  m_file = nullptr;
  if (!flushed) return diskError("cannot write '" + m_path + "'", err);
  PFLOW_TRY(syncPath(m_path, false));
  auto header = readCheckpointHeader(m_path);
  if (!header) return invalidArgument("checkpoint of job '" + m_jobId + "' is not a pflow checkpoint: " + header.status().message());
  if (header->step != m_step)
    return invalidArgument("checkpoint of job '" + m_jobId + "' was announced as step " + std::to_string(m_step) + " but holds step " +
                           std::to_string(header->step));
  const std::string& dir = m_store->m_options.dir;
  const std::string last = lastPath(dir, m_jobId), before = previousCheckpointPath(last);
  std::lock_guard lock(m_store->jobMutex(m_jobId));
  std::error_code ec;
  if (fs::exists(last, ec)) {
    fs::rename(last, before, ec);
    if (ec) return ioError("cannot rename '" + last + "' to '" + before + "': " + ec.message());
  }
  fs::rename(m_path, last, ec);
  if (ec) return ioError("cannot rename '" + m_path + "' to '" + last + "': " + ec.message());
  m_done = true;
  PFLOW_TRY(syncPath(dir, true));
  spdlog::info("job '{}': checkpoint of step {} (t = {:.6g} s, {} bytes) kept", m_jobId, header->step, header->time, m_total);
  return StoredCheckpoint{last, header->step, header->time, m_total, {}};
}

Status CheckpointStore::remove(const std::string& jobId) {
  PFLOW_TRY(validateJobId(jobId));
  const std::string last = lastPath(m_options.dir, jobId);
  for (const std::string& path : {last, previousCheckpointPath(last)}) {
    std::error_code ec;
    fs::remove(path, ec);
    if (ec) return ioError("cannot delete '" + path + "': " + ec.message());
  }
  return Status::ok();
}

Result<StoredCheckpoint> CheckpointStore::latest(const std::string& jobId) const {
  PFLOW_TRY(validateJobId(jobId));
  const std::string last = lastPath(m_options.dir, jobId);
  std::string skipped;
  for (const std::string& path : {last, previousCheckpointPath(last)}) {
    auto header = readCheckpointHeader(path);
    if (!header) {
      if (header.status().code() != StatusCode::kNotFound && skipped.empty()) skipped = header.status().message();
      continue;
    }
    std::error_code ec;
    const auto bytes = fs::file_size(path, ec);
    if (ec) continue;
    if (!skipped.empty()) spdlog::warn("job '{}': {}; the checkpoint before it is sent", jobId, skipped);
    return StoredCheckpoint{path, header->step, header->time, std::uint64_t(bytes), skipped};
  }
  return Status(StatusCode::kNotFound, "job '" + jobId + "' has no checkpoint on the back-end" + (skipped.empty() ? "" : " that reads (" + skipped + ")"));
}

}  // namespace pflow::backend
