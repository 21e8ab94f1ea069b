// The back-end's domain class (no gRPC): snapshots of every job in a data directory, one `<job_id>.h5` plus
// `<job_id>.xmf` per job (layout: backend/store/SnapshotFile.h, docs/output-format.md).
//
// Ingest: beginSnapshot reserves (job, step); appendChunk writes each piece into a scratch HDF5 file
// `<data>/.ingest/<job>.<step>.<serial>.h5` (so the back-end holds one chunk at a time, never the snapshot);
// commit computes the grid fields from the scratch file in blocks of 65536 particles (two passes plus one for
// the bounds), then copies the arrays and the grid into `/snapshots/<step>` of the job file in one step. abort,
// an error, or destroying an unfinished Ingest deletes the scratch file: the job file never holds a partial
// snapshot. Scratch files left by a crash are removed when the store opens.
// Grid: cubic cells of StoreOptions::gridCellSize (m); 0 = 4 x the largest particle radius of each snapshot.
// A grid needs position (n,3), velocity (n,3) and radius (n) arrays; a snapshot without them is stored without
// a grid (logged). Peak ingest memory is one chunk, the geometry, the grid (<= 4 Mi cells x 6 f64) and one block.
// Reading: openRead returns a cursor that reads one piece (<= 1 MiB, a hyperslab of one array) per next().
// Thread safety: every method may be called from any thread; calls for one job are serialized.
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "backend/CheckpointStore.h"
#include "backend/SnapshotChunks.h"
#include "backend/store/SnapshotFile.h"
#include "common/Status.h"

namespace pflow::backend {

struct StoreOptions {
  std::string dataDir;
  double gridCellSize = 0;  // m; 0 = 4 x the largest particle radius of each snapshot
  // Job files kept open at once (each an HDF5 file: a descriptor or more); beyond it the least recently used idle
  // one is closed (and opened again when its job is next written or listed). Bounds the back-end's descriptors
  // however many jobs it has stored.
  std::size_t maxOpenJobFiles = 64;
  // A commit needs the snapshot's bytes plus this much left free on the data directory's file system, or it is
  // refused (RESOURCE_EXHAUSTED, the job file untouched): HDF5 does not survive a disk that fills mid-copy (it
  // crashed the back-end in H5Ocopy).
  std::uint64_t reserveBytes = std::uint64_t(16) << 20;
  // The free bytes of the file system holding a folder (statvfs); tests replace it.
  std::function<std::uint64_t(const std::string& folder)> freeBytes;
};

struct SnapshotInfo {
  std::int64_t step = 0;
  double time = 0;  // s
  std::uint64_t particles = 0;
  bool hasGrid = false;
};

struct JobListing {
  std::string file;  // the job's .h5
  std::vector<SnapshotInfo> snapshots;  // by step
};

struct CommitResult {
  std::string jobId;
  std::int64_t step = 0;
  std::uint64_t bytes = 0;  // payload bytes received
  std::optional<GridSpec> grid;  // the grid computed, if any
};

struct ReadRequest {
  std::optional<std::int64_t> step;  // nullopt = the last stored step
  std::vector<std::string> fields;   // particle arrays to send; empty = all
  bool includeGrid = false;
  bool includeGeometry = false;
  bool includeProbes = false;        // the job's probe series after everything else (Section::kProbes)
  bool particles = true;             // false: no particle arrays (then `fields` must be empty)
};

// Reads one snapshot piece by piece: particle arrays (in stored order or the order asked), then grid fields,
// then geometry. Each next() reads at most kMaxChunkBytes of one array from the file.
class SnapshotCursor {
 public:
  virtual ~SnapshotCursor() = default;
  // The next chunk, or nullopt at the end.
  virtual Result<std::optional<Chunk>> next() = 0;
  virtual const StepMeta& meta() const = 0;
};

class SnapshotStore {
 public:
  // Creates dataDir if needed and removes leftover scratch files. INVALID_ARGUMENT for a bad cell size.
  static Result<std::unique_ptr<SnapshotStore>> open(const StoreOptions& options);
  ~SnapshotStore();
  SnapshotStore(const SnapshotStore&) = delete;
  SnapshotStore& operator=(const SnapshotStore&) = delete;

  // One snapshot being received. Destroying it without commit() aborts.
  class Ingest {
   public:
    ~Ingest();
    // A chunk of the stream: must repeat the job, step, time and n given to beginSnapshot and fit the pieces
    // before it (SnapshotChunks.h). INVALID_ARGUMENT otherwise; the ingest is then useless (abort it).
    Status appendChunk(const Chunk& chunk);
    // Checks completeness, computes the grid, writes the geometry if the job has none yet (the first geometry
    // of a job wins; later ones are ignored), and stores the snapshot. ALREADY_EXISTS if the step is stored.
    Result<CommitResult> commit();
    void abort();
    std::uint64_t bytes() const;

   private:
    friend class SnapshotStore;
    Ingest() = default;
    SnapshotStore* m_store = nullptr;
    std::unique_ptr<ChunkAssembler> m_assembler;
    std::string m_jobId;
    std::int64_t m_step = 0;
    bool m_done = false;
  };

  // Reserves (job, step): INVALID_ARGUMENT for a bad job id, non-finite time or n > 2^32 - 1; UNAVAILABLE while
  // another stream is receiving the step (a retry may come before the earlier try has ended: the spool tries again);
  // ALREADY_EXISTS when the step is stored. Creates the job on first use.
  Result<std::unique_ptr<Ingest>> beginSnapshot(const std::string& jobId, std::int64_t step, double time,
                                                std::uint64_t particles);
  // NOT_FOUND for an unknown job.
  Result<JobListing> list(const std::string& jobId);
  // NOT_FOUND for an unknown job, a step that does not exist, or a job without snapshots when the last is asked;
  // INVALID_ARGUMENT for a field the snapshot does not have (the message lists the ones it has).
  Result<std::unique_ptr<SnapshotCursor>> openRead(const std::string& jobId, const ReadRequest& request);
  // Appends samples to the job's /probes (SnapshotWriter::appendProbes); creates the job on first use. Returns
  // the samples stored in all.
  Result<std::uint64_t> appendProbes(const std::string& jobId, const ProbeSeries& samples);
  // Deletes everything stored for the job: <job>.h5, <job>.xmf and its checkpoints. FAILED_PRECONDITION while a
  // snapshot of it is being received; OK when nothing was stored (deleting twice is not an error). Reads in progress
  // keep the file they opened (POSIX unlink).
  Status removeJob(const std::string& jobId);
  // Streams a snapshot through `sink`, one chunk (<= 1 MiB of data) at a time; stops at the first error.
  Status readChunks(const std::string& jobId, const ReadRequest& request, const std::function<Status(Chunk&&)>& sink);

  // The jobs' checkpoints, in <data>/checkpoints (CheckpointStore.h).
  CheckpointStore& checkpoints() { return *m_checkpoints; }
  double gridCellSize() const { return m_options.gridCellSize; }
  const std::string& dataDir() const { return m_options.dataDir; }
  std::string jobFile(const std::string& jobId) const;  // <data>/<job>.h5

 private:
  struct Job {
    std::mutex mutex;
    std::unique_ptr<SnapshotWriter> writer;  // opened on first use, kept open while among the recently used
    std::set<std::int64_t> receiving;        // steps being ingested
    std::atomic<bool> open{false};           // writer is set (read without the job's lock: closeIdleFiles)
    std::atomic<std::uint64_t> lastUse{0};   // the store's use count at this job's last use
  };
  explicit SnapshotStore(StoreOptions options) : m_options(std::move(options)) {}
  // The job's state, its mutex locked into `lock`. kExisting: NOT_FOUND when the job has no file; kReserve: the
  // writer is opened only if the file exists; kCreate: the file is created if needed.
  enum class JobMode { kExisting, kReserve, kCreate };
  Result<std::shared_ptr<Job>> job(const std::string& jobId, JobMode mode, std::unique_lock<std::mutex>& lock);
  Result<std::optional<GridFields>> computeGrid(SnapshotStaging& staging) const;
  void release(const std::string& jobId, std::int64_t step);
  // An I/O error on a data directory with less than reserveBytes free is a full disk: RESOURCE_EXHAUSTED, which
  // the worker waits out (SpoolingSink), instead of an internal error that fails the job.
  Status fullDiskOr(Status st) const;
  // Closes the least recently used idle job files (not `keep`, not locked, nothing being received) until at most
  // maxOpenJobFiles are open.
  void closeIdleFiles(const Job* keep);

  StoreOptions m_options;
  std::unique_ptr<CheckpointStore> m_checkpoints;
  std::mutex m_mutex;  // m_jobs, m_serial, m_claimedBytes
  std::map<std::string, std::shared_ptr<Job>> m_jobs;
  std::uint64_t m_serial = 0;
  std::atomic<std::uint64_t> m_uses{0};
  std::uint64_t m_claimedBytes = 0;  // bytes commits in progress will write (m_mutex)
};

// OK when jobId is 1..128 characters of [A-Za-z0-9._-], not starting with '.' (no path separators).
Status validateJobId(const std::string& jobId);
// The bytes free for unprivileged writers on the file system holding `folder` (statvfs; the largest value when unknown).
std::uint64_t fileSystemFreeBytes(const std::string& folder);

}  // namespace pflow::backend
