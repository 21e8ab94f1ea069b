// The back-end's store of job checkpoints (issue 18; docs/operations.md, "Checkpoints of jobs"): the bytes of the
// checkpoint files workers send (backend/store/CheckpointFile.h), so that a job the manager requeues resumes on any
// node. Layout: <dir>/<job>.h5 is the job's last checkpoint, <job>.h5.1 the one before.
//
// An upload is written to <dir>/.incoming/<job>.<serial>.h5 chunk by chunk, in order (never whole in memory). Its
// commit flushes the file to disk (fsync), reads its header back (a pflow checkpoint of the step announced, of the
// size announced), then renames the last checkpoint to .1 and the upload over the last (fsync of the folder): a
// cut-off, damaged or mislabelled upload is never kept, and the last two good ones are. Uploads left by a crash are
// removed when the store opens. Thread-safe; commits of one job are serialized.
#pragma once
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "common/Status.h"

namespace pflow::backend {

struct CheckpointStoreOptions {
  std::string dir;
  // An upload is refused (RESOURCE_EXHAUSTED) unless its bytes plus this much stay free on the folder's file system.
  std::uint64_t reserveBytes = std::uint64_t(16) << 20;
  std::function<std::uint64_t(const std::string& folder)> freeBytes;  // statvfs when empty
};

struct StoredCheckpoint {
  std::string path;    // the file to stream
  std::int64_t step = 0;
  double time = 0;     // s
  std::uint64_t bytes = 0;
  std::string skipped;  // why the last one was passed over for the one before (empty: it was not)
};

class CheckpointStore {
 public:
  static Result<std::unique_ptr<CheckpointStore>> open(CheckpointStoreOptions options);

  class Upload {
   public:
    ~Upload();  // an upload never committed is removed
    // The next `size` bytes at `offset` (which must be where the last chunk ended; the total may not be exceeded).
    Status append(std::uint64_t offset, const void* data, std::size_t size);
    // Checks and keeps the checkpoint (see the file comment). INVALID_ARGUMENT for an incomplete upload or a file
    // that is not a checkpoint of the step announced; IO or RESOURCE_EXHAUSTED when the disk fails or fills.
    Result<StoredCheckpoint> commit();

   private:
    friend class CheckpointStore;
    Upload() = default;
    CheckpointStore* m_store = nullptr;
    std::string m_jobId, m_path;
    std::int64_t m_step = 0;
    std::uint64_t m_total = 0, m_written = 0;
    std::FILE* m_file = nullptr;
    bool m_done = false;
  };

  // INVALID_ARGUMENT for a bad job id, a negative step or an empty file; RESOURCE_EXHAUSTED when the disk cannot
  // hold `totalBytes` and the reserve.
  Result<std::unique_ptr<Upload>> begin(const std::string& jobId, std::int64_t step, std::uint64_t totalBytes);
  // The job's last checkpoint that reads back (the one before when the last does not). NOT_FOUND when none does.
  Result<StoredCheckpoint> latest(const std::string& jobId) const;
  // Deletes the job's checkpoints (the last and the one before); OK when there are none.
  Status remove(const std::string& jobId);
  const std::string& dir() const { return m_options.dir; }

 private:
  explicit CheckpointStore(CheckpointStoreOptions options) : m_options(std::move(options)) {}
  std::mutex& jobMutex(const std::string& jobId);

  CheckpointStoreOptions m_options;
  std::mutex m_mu;
  std::map<std::string, std::unique_ptr<std::mutex>> m_jobMutex;
  std::uint64_t m_serial = 0;
};

}  // namespace pflow::backend
