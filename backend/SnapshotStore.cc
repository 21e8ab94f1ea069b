// The back-end's snapshot store. See SnapshotStore.h.
#include "backend/SnapshotStore.h"

#include "common/Log.h"

#include <spdlog/spdlog.h>
#include <sys/statvfs.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <filesystem>
#include <limits>

namespace pflow::backend {
namespace {

namespace fs = std::filesystem;
using compute::ScalarType;

constexpr const char* kIngestDir = ".ingest";
constexpr std::uint64_t kGridBlockRows = 65536;

bool isFloat(const ArrayMeta* a) { return a != nullptr && (a->type == ScalarType::kF64 || a->type == ScalarType::kF32); }

bool hasShape(const ArrayMeta* a, std::uint64_t n, int components) {
  if (a == nullptr || a->shape.empty() || a->shape[0] != n) return false;
  if (components == 1) return a->shape.size() == 1 || (a->shape.size() == 2 && a->shape[1] == 1);
  return a->shape.size() == 2 && a->shape[1] == std::uint64_t(components);
}

std::string stepsText(const std::vector<std::int64_t>& steps) {
  if (steps.empty()) return "it has no snapshots";
  return "it has " + std::to_string(steps.size()) + " snapshot(s), steps " + std::to_string(steps.front()) + " to " +
         std::to_string(steps.back());
}

class FileCursor final : public SnapshotCursor {
 public:
  struct Item {
    Section section;
    ArrayMeta array;
  };

  FileCursor(std::string jobId, std::unique_ptr<SnapshotReader> reader, StepMeta meta, std::vector<Item> items,
             bool geometry, std::optional<ProbeSeries> probes)
      : m_jobId(std::move(jobId)),
        m_reader(std::move(reader)),
        m_meta(std::move(meta)),
        m_items(std::move(items)),
        m_geometry(geometry),
        m_probes(std::move(probes)) {}

  const StepMeta& meta() const override { return m_meta; }

  Result<std::optional<Chunk>> next() override {
    while (m_item < m_items.size()) {
      const Item& it = m_items[m_item];
      const std::uint64_t rows = it.array.rows();
      if (rows == 0 || m_row < rows) {
        const std::uint64_t count = std::min(rowsPerPiece(it.array.rowBytes()), rows - m_row);
        Chunk c = header(it.section);
        ArrayPiece& p = c.array;
        p.name = it.array.name;
        p.dtype = *dtypeOf(it.array.type);
        p.shape = it.array.shape;
        p.firstRow = m_row;
        p.rows = count;
        p.unit = it.array.unit;
        Status st = it.section == Section::kGrid
                        ? m_reader->readGridRows(m_meta.step, it.array.name, m_row, count, p.data)
                        : m_reader->readRows(m_meta.step, it.array.name, m_row, count, p.data);
        if (!st) return st;
        if (it.section == Section::kGrid) c.grid = m_meta.grid->spec;
        m_row += count;
        if (m_row >= rows) {
          ++m_item;
          m_row = 0;
        }
        return std::optional<Chunk>(std::move(c));
      }
      ++m_item;
      m_row = 0;
    }
    if (m_geometry) {
      m_geometry = false;
      auto geo = m_reader->readGeometry();
      if (!geo) return geo.status();
      if (Status st = geometryPieces(geo.value(), [&](ArrayPiece&& p) {
            m_pieces.push_back(std::move(p));
            return Status::ok();
          });
          !st)
        return st;
    }
    if (!m_pieces.empty()) {
      Chunk c = header(Section::kGeometry);
      c.array = std::move(m_pieces.front());
      m_pieces.pop_front();
      return std::optional<Chunk>(std::move(c));
    }
    // The probe series: "time", then each probe's values, in pieces of whole rows.
    if (m_probes) {
      const ProbeSeries& s = *m_probes;
      while (m_probe <= s.names.size()) {
        const std::vector<double>& v = m_probe == 0 ? s.time : s.values[m_probe - 1];
        if (m_probeRow >= v.size() && !(v.empty() && m_probeRow == 0 && !m_probeEmptySent)) {
          ++m_probe;
          m_probeRow = 0;
          m_probeEmptySent = false;
          continue;
        }
        Chunk c = header(Section::kProbes);
        ArrayPiece& p = c.array;
        p.name = m_probe == 0 ? "time" : s.names[m_probe - 1];
        p.unit = m_probe == 0 ? "s" : s.units[m_probe - 1];
        if (m_probe > 0) c.point = s.points[m_probe - 1];
        p.dtype = DType::kF64;
        p.shape = {v.size()};
        p.firstRow = m_probeRow;
        p.rows = std::min<std::uint64_t>(rowsPerPiece(sizeof(double)), v.size() - m_probeRow);
        p.data.assign(reinterpret_cast<const char*>(v.data() + m_probeRow), p.rows * sizeof(double));
        m_probeRow += p.rows;
        m_probeEmptySent = true;
        return std::optional<Chunk>(std::move(c));
      }
      m_probes.reset();
    }
    return std::optional<Chunk>();
  }

 private:
  Chunk header(Section section) const {
    Chunk c;
    c.jobId = m_jobId;
    c.step = m_meta.step;
    c.time = m_meta.time;
    c.particles = m_meta.n;
    c.section = section;
    return c;
  }

  std::string m_jobId;
  std::unique_ptr<SnapshotReader> m_reader;
  StepMeta m_meta;
  std::vector<Item> m_items;
  bool m_geometry;
  std::deque<ArrayPiece> m_pieces;  // geometry, cut once it is reached
  std::size_t m_item = 0;
  std::uint64_t m_row = 0;
  std::optional<ProbeSeries> m_probes;  // still to send
  std::size_t m_probe = 0;              // 0: time, k: probe k - 1
  std::uint64_t m_probeRow = 0;
  bool m_probeEmptySent = false;        // an empty series still sends one empty piece per array
};

}  // namespace

Status validateJobId(const std::string& jobId) {
  if (jobId.empty()) return invalidArgument("job id is empty");
  if (jobId.size() > 128) return invalidArgument("job id is longer than 128 characters");
  if (jobId.front() == '.') return invalidArgument("job id '" + log::escaped(jobId) + "' starts with '.'");
  for (char c : jobId) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-';
    if (!ok)
      return invalidArgument("job id '" + log::escaped(jobId) + "' has a character other than letters, digits, '.', '_' and '-'");
  }
  return Status::ok();
}

std::uint64_t fileSystemFreeBytes(const std::string& folder) {
  struct statvfs v {};
  if (::statvfs(folder.c_str(), &v) != 0) return std::numeric_limits<std::uint64_t>::max();  // unknown: not refused here
  return std::uint64_t(v.f_bavail) * std::uint64_t(v.f_frsize);
}

Result<std::unique_ptr<SnapshotStore>> SnapshotStore::open(const StoreOptions& options) {
  if (options.dataDir.empty()) return invalidArgument("data directory is empty");
  if (!std::isfinite(options.gridCellSize) || options.gridCellSize < 0)
    return invalidArgument("grid cell size must be >= 0 m (0 = 4 x the largest particle radius)");
  std::error_code ec;
  const fs::path scratch = fs::path(options.dataDir) / kIngestDir;
  fs::create_directories(scratch, ec);
  if (ec) return ioError(scratch.string() + ": cannot create: " + ec.message());
  std::size_t removed = 0;
  for (const auto& entry : fs::directory_iterator(scratch, ec)) {
    std::error_code rm;
    if (fs::remove(entry.path(), rm)) ++removed;
  }
  if (removed > 0) spdlog::info("removed {} scratch file(s) of unfinished ingests in {}", removed, scratch.string());
  StoreOptions o = options;
  if (!o.freeBytes) o.freeBytes = fileSystemFreeBytes;
  auto checkpoints = CheckpointStore::open({(fs::path(o.dataDir) / "checkpoints").string(), o.reserveBytes, o.freeBytes});
  if (!checkpoints) return checkpoints.status();
  std::unique_ptr<SnapshotStore> store(new SnapshotStore(std::move(o)));
  store->m_checkpoints = std::move(checkpoints).value();
  return store;
}

SnapshotStore::~SnapshotStore() = default;

Status SnapshotStore::removeJob(const std::string& jobId) {
  if (Status st = validateJobId(jobId); !st) return st;
  std::shared_ptr<Job> j;
  {
    std::lock_guard guard(m_mutex);
    if (auto it = m_jobs.find(jobId); it != m_jobs.end()) j = it->second;
  }
  std::unique_lock<std::mutex> lock;
  if (j) {
    lock = std::unique_lock(j->mutex);
    if (!j->receiving.empty()) return failedPrecondition("job '" + jobId + "' is receiving a snapshot now; delete it once it has ended");
    j->writer.reset();
    j->open = false;
  }
  const std::string h5 = jobFile(jobId);
  for (const std::string& path : {h5, h5.substr(0, h5.size() - 3) + ".xmf"}) {
    std::error_code ec;
    fs::remove(path, ec);
    if (ec) return ioError("cannot delete '" + path + "': " + ec.message());
  }
  if (j) {
    std::lock_guard guard(m_mutex);
    m_jobs.erase(jobId);
  }
  return m_checkpoints->remove(jobId);
}

std::string SnapshotStore::jobFile(const std::string& jobId) const {
  return (fs::path(m_options.dataDir) / (jobId + ".h5")).string();
}

Result<std::shared_ptr<SnapshotStore::Job>> SnapshotStore::job(const std::string& jobId, JobMode mode,
                                                               std::unique_lock<std::mutex>& lock) {
  if (Status st = validateJobId(jobId); !st) return st;
  const std::string path = jobFile(jobId);
  std::shared_ptr<Job> j;
  {
    std::lock_guard guard(m_mutex);
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) {
      std::error_code ec;
      if (mode == JobMode::kExisting && !fs::exists(path, ec))
        return notFound("unknown job '" + jobId + "': no snapshots stored");
      it = m_jobs.emplace(jobId, std::make_shared<Job>()).first;
    }
    j = it->second;
  }
  lock = std::unique_lock(j->mutex);
  j->lastUse = ++m_uses;
  if (!j->writer) {
    std::error_code ec;
    if (mode != JobMode::kCreate && !fs::exists(path, ec)) return j;  // known (an ingest runs) but nothing stored
    auto writer = SnapshotWriter::openOrCreate(path);
    if (!writer) return writer.status();
    j->writer = std::move(writer.value());
    j->open = true;
    closeIdleFiles(j.get());
  }
  return j;
}

void SnapshotStore::closeIdleFiles(const Job* keep) {
  std::vector<std::pair<std::uint64_t, std::shared_ptr<Job>>> open;  // last use as read now: other threads move it on
  {
    std::lock_guard guard(m_mutex);
    for (const auto& [id, j] : m_jobs)
      if (j->open && j.get() != keep) open.emplace_back(j->lastUse.load(), j);
  }
  const std::size_t most = std::max<std::size_t>(1, m_options.maxOpenJobFiles);
  if (open.size() + 1 <= most) return;
  std::sort(open.begin(), open.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::size_t count = open.size() + 1;
  for (const auto& [use, j] : open) {
    if (count <= most) break;
    std::unique_lock lock(j->mutex, std::try_to_lock);  // a job in use now is skipped (never waited for: we hold `keep`)
    if (!lock || !j->writer || !j->receiving.empty()) continue;
    j->writer.reset();
    j->open = false;
    --count;
  }
}

static std::string mib(std::uint64_t bytes) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f MiB", double(bytes) / double(1 << 20));
  return b;
}

Status SnapshotStore::fullDiskOr(Status st) const {
  if (st.code() != StatusCode::kIo) return st;
  const std::uint64_t free = m_options.freeBytes(m_options.dataDir);
  if (free >= m_options.reserveBytes) return st;
  return Status(StatusCode::kResourceExhausted, "the disk holding " + m_options.dataDir + " is full (" + mib(free) + " free): " + st.message());
}

void SnapshotStore::release(const std::string& jobId, std::int64_t step) {
  std::shared_ptr<Job> j;
  {
    std::lock_guard guard(m_mutex);
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) return;
    j = it->second;
  }
  std::lock_guard lock(j->mutex);
  j->receiving.erase(step);
}

Result<std::unique_ptr<SnapshotStore::Ingest>> SnapshotStore::beginSnapshot(const std::string& jobId,
                                                                           std::int64_t step, double time,
                                                                           std::uint64_t particles) {
  if (!std::isfinite(time)) return invalidArgument("snapshot step " + std::to_string(step) + ": time is not finite");
  if (particles > std::numeric_limits<std::uint32_t>::max())
    return invalidArgument("snapshot step " + std::to_string(step) + ": " + std::to_string(particles) +
                           " particles exceed the supported 4294967295");
  std::unique_lock<std::mutex> lock;
  auto j = job(jobId, JobMode::kReserve, lock);
  if (!j) return j.status();
  Job& jb = *j.value();
  if (jb.writer && jb.writer->hasStep(step))
    return alreadyExists("job '" + jobId + "' already has a snapshot for step " + std::to_string(step));
  if (jb.receiving.count(step) != 0)
    return unavailable("job '" + jobId + "': step " + std::to_string(step) +
                       " is being written by another stream (an earlier try still being received): try again");
  std::uint64_t serial;
  {
    std::lock_guard guard(m_mutex);
    serial = ++m_serial;
  }
  const std::string scratch = (fs::path(m_options.dataDir) / kIngestDir /
                               (jobId + "." + std::to_string(step) + "." + std::to_string(serial) + ".h5"))
                                  .string();
  Chunk first;
  first.jobId = jobId;
  first.step = step;
  first.time = time;
  first.particles = particles;
  auto assembler = ChunkAssembler::create(scratch, first);
  if (!assembler) return fullDiskOr(assembler.status());
  jb.receiving.insert(step);
  auto ingest = std::unique_ptr<Ingest>(new Ingest());
  ingest->m_store = this;
  ingest->m_assembler = std::move(assembler.value());
  ingest->m_jobId = jobId;
  ingest->m_step = step;
  return ingest;
}

SnapshotStore::Ingest::~Ingest() { abort(); }

std::uint64_t SnapshotStore::Ingest::bytes() const { return m_assembler ? m_assembler->bytes() : 0; }

Status SnapshotStore::Ingest::appendChunk(const Chunk& chunk) {
  if (m_done) return failedPrecondition("the ingest of step " + std::to_string(m_step) + " is finished");
  Status st = m_store->fullDiskOr(m_assembler->add(chunk));
  if (!st)
    return {st.code(), "job '" + m_jobId + "' step " + std::to_string(m_step) + ": " + st.message()};
  return Status::ok();
}

void SnapshotStore::Ingest::abort() {
  if (m_done) return;
  m_done = true;
  // The reservation goes first: once the scratch file is gone (what callers can see), the step is free again.
  // Scratch names carry a serial, so a new stream for the step never meets this one's file.
  m_store->release(m_jobId, m_step);
  m_assembler.reset();  // removes the scratch file
}

Result<CommitResult> SnapshotStore::Ingest::commit() {
  if (m_done) return failedPrecondition("the ingest of step " + std::to_string(m_step) + " is finished");
  const std::string where = "job '" + m_jobId + "' step " + std::to_string(m_step) + ": ";
  auto fail = [&](const Status& failed) -> Status {
    const Status st = m_store->fullDiskOr(failed);  // before the scratch file goes and frees its space
    abort();
    return {st.code(), where + st.message()};
  };
  if (Status st = m_assembler->checkComplete(); !st) return fail(st);
  auto grid = m_store->computeGrid(m_assembler->staging());
  if (!grid) return fail(grid.status());
  std::optional<compute::GeometrySnapshot> geometry;
  if (!m_assembler->geometry().empty()) {
    auto g = m_assembler->geometry().take();
    if (!g) return fail(g.status());
    geometry = std::move(g.value());
  }
  // Room first: the arrays and the grid, copied into the job file, plus the reserve. What commits running now will
  // write counts as taken (claimed until each ends), so two of them cannot both pass on the same free bytes.
  std::uint64_t claim = 0;
  std::string refused;
  {
    std::uint64_t bytes = 0;
    for (const ArrayMeta& a : m_assembler->staging().meta().arrays) bytes += a.rows() * a.rowBytes();
    if (grid.value()) {
      const GridFields& g = *grid.value();
      bytes += 8 * (g.solidFraction.size() + g.meanVelocity.size() + g.granularTemperature.size() + g.meanPressure.size());
    }
    const std::uint64_t needed = bytes + m_store->m_options.reserveBytes;
    std::lock_guard guard(m_store->m_mutex);
    const std::uint64_t free = m_store->m_options.freeBytes(m_store->m_options.dataDir);
    const std::uint64_t claimed = m_store->m_claimedBytes;
    if (free < needed + claimed) {
      refused = "the disk holding " + m_store->m_options.dataDir + " has " + mib(free) + " free" +
                (claimed ? " (" + mib(claimed) + " of it claimed by snapshots being stored)" : std::string()) + "; this snapshot needs " +
                mib(needed) + " with the " + mib(m_store->m_options.reserveBytes) +
                " kept free: refused, nothing written (free space, then send it again)";
    } else {
      claim = bytes;
      m_store->m_claimedBytes += claim;
    }
  }
  if (!refused.empty()) return fail(Status(StatusCode::kResourceExhausted, refused));
  struct Unclaim {
    SnapshotStore* store;
    std::uint64_t bytes;
    ~Unclaim() {
      std::lock_guard guard(store->m_mutex);
      store->m_claimedBytes -= bytes;
    }
  } unclaim{m_store, claim};
  CommitResult result;
  result.jobId = m_jobId;
  result.step = m_step;
  result.bytes = m_assembler->bytes();
  if (grid.value()) result.grid = grid.value()->spec;
  Status stored = [&]() -> Status {  // under the job's lock, which abort() takes too
    std::unique_lock<std::mutex> lock;
    auto j = m_store->job(m_jobId, JobMode::kCreate, lock);
    if (!j) return j.status();
    SnapshotWriter& writer = *j.value()->writer;
    if (writer.hasStep(m_step)) return alreadyExists("the step is already stored");
    if (geometry && !writer.hasGeometry()) {
      if (Status st = writer.writeGeometry(*geometry); !st) return st;
    }
    const GridFields* fields = grid.value() ? &*grid.value() : nullptr;
    return writer.commit(m_assembler->staging(), fields);
  }();
  if (!stored) return fail(stored);
  abort();  // done: drop the scratch file and the reservation
  return result;
}

Result<std::optional<GridFields>> SnapshotStore::computeGrid(SnapshotStaging& staging) const {
  const StepMeta& m = staging.meta();
  const ArrayMeta* position = m.find("position");
  const ArrayMeta* velocity = m.find("velocity");
  const ArrayMeta* radius = m.find("radius");
  const ArrayMeta* mass = m.find("mass");
  const ArrayMeta* density = m.find("density");
  const ArrayMeta* pressure = m.find("pressure");
  const ArrayMeta* kind = m.find("kind");
  // A fluid (SPH) snapshot: no radius; each fluid particle's sphere from its volume m / rho (GridFields.h).
  const bool fluid = radius == nullptr && isFloat(mass) && hasShape(mass, m.n, 1) && isFloat(density) && hasShape(density, m.n, 1);
  if (!(isFloat(position) && hasShape(position, m.n, 3) && isFloat(velocity) && hasShape(velocity, m.n, 3) &&
        (fluid || (isFloat(radius) && hasShape(radius, m.n, 1))))) {
    spdlog::info("step {}: no grid fields (they need f64/f32 position (n,3), velocity (n,3) and radius (n), or mass and density (n) for a fluid)",
                 m.step);
    return std::optional<GridFields>();
  }
  if (m.n == 0) return std::optional<GridFields>();
  const bool withMass = isFloat(mass) && hasShape(mass, m.n, 1);
  const bool withPressure = fluid && isFloat(pressure) && hasShape(pressure, m.n, 1);
  const bool withKind = fluid && kind != nullptr && hasShape(kind, m.n, 1);
  std::vector<double> x, v, r, w, p, rho, k;
  std::vector<std::uint8_t> excluded;
  // A planar (2D) fluid: every fluid particle at one y (GridFields.h); found in a pass of its own.
  PlaneCheck plane;
  for (std::uint64_t first = 0; fluid && first < m.n && plane.same; first += kGridBlockRows) {
    const std::uint64_t rows = std::min(kGridBlockRows, m.n - first);
    if (Status st = staging.readParticleRowsF64("position", first, rows, x); !st) return st;
    excluded.assign(rows, 0);
    if (withKind) {
      if (Status st = staging.readParticleRowsF64("kind", first, rows, k); !st) return st;
      for (std::uint64_t i = 0; i < rows; ++i) excluded[i] = k[i] != 0;
    }
    plane.add(rows, x.data(), excluded.data());
  }
  const bool planar = fluid && plane.planar();
  auto load = [&](std::uint64_t first, std::uint64_t rows, bool velocities) -> Result<ParticleBlock> {
    if (Status st = staging.readParticleRowsF64("position", first, rows, x); !st) return st;
    if (fluid) {
      if (Status st = staging.readParticleRowsF64("mass", first, rows, w); !st) return st;
      if (Status st = staging.readParticleRowsF64("density", first, rows, rho); !st) return st;
      if (withKind)
        if (Status st = staging.readParticleRowsF64("kind", first, rows, k); !st) return st;
      r.resize(rows);
      excluded.assign(rows, 0);
      for (std::uint64_t i = 0; i < rows; ++i) {
        excluded[i] = withKind && k[i] != 0;  // boundary particles are not fluid
        r[i] = excluded[i] ? 0.0 : fluidRadius(w[i], rho[i], planar);
      }
    } else if (Status st = staging.readParticleRowsF64("radius", first, rows, r); !st) {
      return st;
    }
    if (velocities) {
      if (Status st = staging.readParticleRowsF64("velocity", first, rows, v); !st) return st;
      if (withMass && !fluid)
        if (Status st = staging.readParticleRowsF64("mass", first, rows, w); !st) return st;
      if (withPressure)
        if (Status st = staging.readParticleRowsF64("pressure", first, rows, p); !st) return st;
    }
    return ParticleBlock{rows,
                         x.data(),
                         v.data(),
                         r.data(),
                         withMass ? w.data() : nullptr,
                         withPressure ? p.data() : nullptr,
                         fluid ? excluded.data() : nullptr};
  };
  ParticleBounds bounds;
  for (std::uint64_t first = 0; first < m.n; first += kGridBlockRows) {
    auto b = load(first, std::min(kGridBlockRows, m.n - first), false);
    if (!b) return b.status();
    bounds.add(b->n, b->position, b->radius);
  }
  if (bounds.count == 0) return std::optional<GridFields>();  // no fluid particle (or none usable)
  if (planar) bounds.flattenY();
  auto spec = gridCovering(bounds, m_options.gridCellSize);
  if (!spec) {
    spdlog::warn("step {}: no grid fields: {}", m.step, spec.status().message());
    return std::optional<GridFields>();
  }
  if (planar) spec->origin.y = plane.y - 0.5 * spec->cellSize;  // the one layer of cells centred on the plane
  GridAccumulator acc(spec.value(), withPressure, fluid, planar);
  for (int pass = 0; pass < (fluid ? 1 : 2); ++pass) {
    for (std::uint64_t first = 0; first < m.n; first += kGridBlockRows) {
      auto b = load(first, std::min(kGridBlockRows, m.n - first), true);
      if (!b) return b.status();
      if (pass == 0) acc.addMoments(b.value());
      else acc.addFluctuations(b.value());
    }
    if (pass == 0) acc.endMoments();
  }
  GridFields fields = std::move(acc).finish();
  if (fields.skippedParticles > 0)
    spdlog::warn("step {}: {} particle(s) with a non-finite state or radius <= 0 left out of the grid fields", m.step,
                 fields.skippedParticles);
  return std::optional<GridFields>(std::move(fields));
}

Result<JobListing> SnapshotStore::list(const std::string& jobId) {
  std::unique_lock<std::mutex> lock;
  auto j = job(jobId, JobMode::kExisting, lock);
  if (!j) return j.status();
  if (!j.value()->writer) return notFound("unknown job '" + jobId + "': no snapshots stored yet");
  auto reader = SnapshotReader::open(jobFile(jobId));
  if (!reader) return reader.status();
  lock.unlock();
  JobListing listing;
  listing.file = jobFile(jobId);
  for (std::int64_t step : reader.value()->steps()) {
    auto meta = reader.value()->meta(step);
    if (!meta) return meta.status();
    listing.snapshots.push_back({step, meta->time, meta->n, meta->grid.has_value()});
  }
  return listing;
}

Result<std::unique_ptr<SnapshotCursor>> SnapshotStore::openRead(const std::string& jobId, const ReadRequest& request) {
  std::unique_lock<std::mutex> lock;
  auto j = job(jobId, JobMode::kExisting, lock);
  if (!j) return j.status();
  if (!j.value()->writer) return notFound("unknown job '" + jobId + "': no snapshots stored yet");
  const std::vector<std::int64_t> steps = j.value()->writer->steps();
  if (steps.empty()) return notFound("job '" + jobId + "' has no snapshots");
  const std::int64_t step = request.step.value_or(steps.back());
  if (!std::binary_search(steps.begin(), steps.end(), step))
    return notFound("job '" + jobId + "' has no snapshot for step " + std::to_string(step) + " (" + stepsText(steps) +
                    ")");
  auto reader = SnapshotReader::open(jobFile(jobId));
  if (!reader) return reader.status();
  lock.unlock();
  auto meta = reader.value()->meta(step);
  if (!meta) return meta.status();

  std::vector<FileCursor::Item> items;
  if (!request.particles && !request.fields.empty()) return invalidArgument("fields named without particle arrays asked for");
  if (!request.particles) {
  } else if (request.fields.empty()) {
    for (const auto& a : meta->arrays) items.push_back({Section::kParticles, a});
  } else {
    for (const auto& name : request.fields) {
      const ArrayMeta* a = meta->find(name);
      if (a == nullptr) {
        std::string have;
        for (const auto& b : meta->arrays) have += (have.empty() ? "" : ", ") + b.name;
        return invalidArgument("job '" + jobId + "' step " + std::to_string(step) + " has no field '" + name +
                               "' (it has: " + have + ")");
      }
      const bool dup = std::any_of(items.begin(), items.end(), [&](const auto& i) { return i.array.name == name; });
      if (!dup) items.push_back({Section::kParticles, *a});
    }
  }
  for (const auto& item : items)
    if (!dtypeOf(item.array.type))
      return invalidArgument("field '" + item.array.name + "' is " + compute::scalarName(item.array.type) +
                             ", which the snapshot protocol cannot carry");
  if (request.includeGrid && meta->grid)
    for (const auto& a : meta->grid->arrays) {
      if (!dtypeOf(a.type) || a.rowBytes() > kMaxChunkBytes)
        return invalidArgument("grid array '" + a.name + "' cannot be sent in 1 MiB chunks");
      items.push_back({Section::kGrid, a});
    }
  const bool geometry = request.includeGeometry && reader.value()->hasGeometry();
  std::optional<ProbeSeries> probes;
  if (request.includeProbes) {
    auto read = reader.value()->readProbes();
    if (read) probes = std::move(read).value();
    else if (read.status().code() != StatusCode::kNotFound) return read.status();
  }
  return std::unique_ptr<SnapshotCursor>(new FileCursor(jobId, std::move(reader.value()), std::move(meta.value()), std::move(items),
                                                        geometry, std::move(probes)));
}

Result<std::uint64_t> SnapshotStore::appendProbes(const std::string& jobId, const ProbeSeries& samples) {
  std::unique_lock<std::mutex> lock;
  auto j = job(jobId, JobMode::kCreate, lock);
  if (!j) return j.status();
  auto stored = j.value()->writer->appendProbes(samples);
  if (!stored) return fullDiskOr(stored.status());
  return stored;
}

Status SnapshotStore::readChunks(const std::string& jobId, const ReadRequest& request,
                                 const std::function<Status(Chunk&&)>& sink) {
  auto cursor = openRead(jobId, request);
  if (!cursor) return cursor.status();
  for (;;) {
    auto chunk = cursor.value()->next();
    if (!chunk) return chunk.status();
    if (!chunk->has_value()) return Status::ok();
    if (Status st = sink(std::move(**chunk)); !st) return st;
  }
}

}  // namespace pflow::backend
