// SnapshotStore: ingest in chunks, commit/abort, list, streaming reads, grid fields, bad input.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "backend/SnapshotStore.h"

namespace pflow::backend {
namespace {

namespace fs = std::filesystem;
using compute::GeometrySnapshot;
using compute::ParticleSnapshot;
using compute::ScalarType;
using compute::SnapshotArray;

template <class T>
SnapshotArray makeArray(const std::string& name, ScalarType type, int components, const std::string& unit,
                        const std::vector<T>& v) {
  SnapshotArray a{name, type, components, unit, {}};
  a.data.resize(v.size() * sizeof(T));
  if (!v.empty()) std::memcpy(a.data.data(), v.data(), a.data.size());
  return a;
}

// n particles on a lattice with known velocities; arrays of several types.
ParticleSnapshot makeSnapshot(std::int64_t step, std::size_t n) {
  ParticleSnapshot s;
  s.step = step;
  s.time = 1e-3 * double(step);
  s.n = n;
  std::vector<double> x(3 * n), v(3 * n), r(n, 0.5e-3);
  std::vector<std::uint64_t> id(n);
  std::vector<std::int32_t> material(n);
  std::vector<float> w(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    x[3 * i] = 1e-3 * double(i % 50);
    x[3 * i + 1] = 1e-3 * double((i / 50) % 50);
    x[3 * i + 2] = 1e-3 * double(i / 2500);
    v[3 * i] = (i % 2 == 0) ? 1.0 : -1.0;
    v[3 * i + 2] = 0.25;
    id[i] = (std::uint64_t(1) << 40) + i;
    material[i] = int(i % 3);
    w[3 * i + 1] = float(i) * 0.5f;
  }
  s.arrays = {makeArray("position", ScalarType::kF64, 3, "m", x), makeArray("velocity", ScalarType::kF64, 3, "m/s", v),
              makeArray("radius", ScalarType::kF64, 1, "m", r), makeArray("id", ScalarType::kU64, 1, "", id),
              makeArray("material", ScalarType::kI32, 1, "", material),
              makeArray("angular_velocity", ScalarType::kF32, 3, "rad/s", w)};
  return s;
}

GeometrySnapshot makeGeometry() {
  GeometrySnapshot g;
  g.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  g.triangles = {0, 1, 2};
  g.triangleMesh = {0};
  g.triangleSurface = {1};
  g.triangleMaterial = {0};
  g.meshNames = {"floor"};
  g.planePoints = {{0, 0, -1}};
  g.planeNormals = {{0, 0, 1}};
  g.planeNames = {"ground"};
  g.planeSurface = {0};
  g.surfaceNames = {"ground", "floor"};
  return g;
}

Status sendAll(SnapshotStore::Ingest& ingest, const std::string& job, const ParticleSnapshot& s,
               const GeometrySnapshot* geometry) {
  auto send = [&](Section section) {
    return [&, section](ArrayPiece&& p) {
      Chunk c{job, s.step, s.time, s.n, section, std::move(p), std::nullopt};
      return ingest.appendChunk(c);
    };
  };
  for (const auto& a : s.arrays)
    if (Status st = particlePieces(a, s.n, send(Section::kParticles)); !st) return st;
  if (geometry != nullptr) return geometryPieces(*geometry, send(Section::kGeometry));
  return Status::ok();
}

Result<CommitResult> store(SnapshotStore& st, const std::string& job, const ParticleSnapshot& s,
                           const GeometrySnapshot* geometry = nullptr) {
  auto ingest = st.beginSnapshot(job, s.step, s.time, s.n);
  if (!ingest) return ingest.status();
  if (Status e = sendAll(*ingest.value(), job, s, geometry); !e) return e;
  return ingest.value()->commit();
}

// Reads a snapshot back through readChunks, reassembling arrays by name.
struct ReadBack {
  std::map<std::string, std::string> particles, grid;
  std::map<std::string, std::vector<std::uint64_t>> shapes;
  std::optional<GridSpec> spec;
  std::vector<std::string> order;
  std::size_t chunks = 0, maxBytes = 0;
  bool geometry = false;
  std::int64_t step = 0;
};

Result<ReadBack> readBack(SnapshotStore& st, const std::string& job, const ReadRequest& request) {
  ReadBack rb;
  Status s = st.readChunks(job, request, [&](Chunk&& c) {
    ++rb.chunks;
    rb.step = c.step;
    rb.maxBytes = std::max(rb.maxBytes, c.array.data.size());
    if (c.section == Section::kGeometry) {
      rb.geometry = true;
      return Status::ok();
    }
    auto& target = c.section == Section::kGrid ? rb.grid : rb.particles;
    if (c.section == Section::kGrid) rb.spec = c.grid;
    if (c.array.firstRow == 0) rb.order.push_back(c.array.name);
    target[c.array.name] += c.array.data;
    rb.shapes[c.array.name] = c.array.shape;
    return Status::ok();
  });
  if (!s) return s;
  return rb;
}

std::string bytesOf(const SnapshotArray& a) { return std::string(reinterpret_cast<const char*>(a.data.data()), a.data.size()); }

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("pflow_store_" + std::to_string(::getpid()) + "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    auto s = SnapshotStore::open({dir.string(), 0.0});
    ASSERT_TRUE(s) << s.status().toString();
    st = std::move(s.value());
  }
  void TearDown() override {
    st.reset();
    fs::remove_all(dir);
  }
  std::size_t scratchFiles() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / ".ingest")) ++n;
    return n;
  }
  fs::path dir;
  std::unique_ptr<SnapshotStore> st;
};

TEST_F(StoreTest, IngestListAndReadBackInChunks) {
  // 150 000 particles: several chunks per array, and three grid blocks of 65 536 at commit, so the block-wise grid
  // is checked against the one-pass in-memory computation below.
  const auto s = makeSnapshot(10, 150000);
  const auto geometry = makeGeometry();
  auto committed = store(*st, "job-1", s, &geometry);
  ASSERT_TRUE(committed) << committed.status().toString();
  ASSERT_TRUE(committed->grid.has_value());
  EXPECT_DOUBLE_EQ(committed->grid->cellSize, 2e-3);  // 4 x 0.5 mm
  EXPECT_EQ(scratchFiles(), 0u);
  ASSERT_TRUE(store(*st, "job-1", makeSnapshot(20, 100)));

  auto listing = st->list("job-1");
  ASSERT_TRUE(listing) << listing.status().toString();
  ASSERT_EQ(listing->snapshots.size(), 2u);
  EXPECT_EQ(listing->snapshots[0].step, 10);
  EXPECT_EQ(listing->snapshots[0].particles, 150000u);
  EXPECT_DOUBLE_EQ(listing->snapshots[0].time, 1e-2);
  EXPECT_TRUE(listing->snapshots[0].hasGrid);
  EXPECT_EQ(listing->file, (dir / "job-1.h5").string());
  EXPECT_TRUE(fs::exists(dir / "job-1.xmf"));

  auto rb = readBack(*st, "job-1", {10, {}, true, true});
  ASSERT_TRUE(rb) << rb.status().toString();
  EXPECT_LE(rb->maxBytes, kMaxChunkBytes);
  EXPECT_GT(rb->chunks, 6u);
  ASSERT_EQ(rb->particles.size(), s.arrays.size());
  for (std::size_t i = 0; i < s.arrays.size(); ++i) {
    EXPECT_EQ(rb->order[i], s.arrays[i].name);
    EXPECT_TRUE(rb->particles[s.arrays[i].name] == bytesOf(s.arrays[i])) << s.arrays[i].name;
  }
  EXPECT_EQ(rb->shapes["position"], (std::vector<std::uint64_t>{150000, 3}));
  EXPECT_EQ(rb->shapes["id"], (std::vector<std::uint64_t>{150000}));
  ASSERT_TRUE(rb->spec.has_value());
  EXPECT_EQ(rb->grid.size(), 3u);
  EXPECT_TRUE(rb->geometry);

  // The grid equals the in-memory computation; alternating +-1 m/s in x gives T = 1/3 m^2/s^2 where full.
  auto expected = computeGridFields(s, 0.0);
  ASSERT_TRUE(expected);
  const auto& sf = rb->grid[kSolidFractionName];
  ASSERT_EQ(sf.size(), expected->solidFraction.size() * sizeof(double));
  EXPECT_EQ(std::memcmp(sf.data(), expected->solidFraction.data(), sf.size()), 0);
  const auto& t = rb->grid[kGranularTemperatureName];
  ASSERT_EQ(t.size(), expected->granularTemperature.size() * sizeof(double));
  EXPECT_EQ(std::memcmp(t.data(), expected->granularTemperature.data(), t.size()), 0);
  const auto& mv = rb->grid[kMeanVelocityName];
  ASSERT_EQ(mv.size(), expected->meanVelocity.size() * sizeof(expected->meanVelocity[0]));
  EXPECT_EQ(std::memcmp(mv.data(), expected->meanVelocity.data(), mv.size()), 0);
  EXPECT_EQ(rb->shapes[kMeanVelocityName], (std::vector<std::uint64_t>{expected->spec.cells[0], expected->spec.cells[1],
                                                                       expected->spec.cells[2], 3}));

  // Last, and a subset of fields in the order asked.
  auto last = readBack(*st, "job-1", {std::nullopt, {"radius", "position"}, false, false});
  ASSERT_TRUE(last);
  EXPECT_EQ(last->step, 20);
  EXPECT_EQ(last->order, (std::vector<std::string>{"radius", "position"}));
  EXPECT_TRUE(last->grid.empty());
  EXPECT_FALSE(last->geometry);
}

TEST_F(StoreTest, PartialReadsAreHyperslabs) {
  const auto s = makeSnapshot(1, 5000);
  ASSERT_TRUE(store(*st, "j", s));
  auto reader = SnapshotReader::open((dir / "j.h5").string());
  ASSERT_TRUE(reader);
  std::string out;
  ASSERT_TRUE(reader.value()->readRows(1, "position", 1234, 100, out));
  EXPECT_EQ(out, bytesOf(s.arrays[0]).substr(1234 * 24, 100 * 24));
  ASSERT_TRUE(reader.value()->readRows(1, "id", 4999, 1, out));
  EXPECT_EQ(out, bytesOf(s.arrays[3]).substr(4999 * 8, 8));
  ASSERT_TRUE(reader.value()->readRows(1, "id", 5000, 0, out));
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(reader.value()->readRows(1, "id", 4990, 11, out).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(reader.value()->readRows(1, "nope", 0, 1, out).code(), StatusCode::kNotFound);
  EXPECT_EQ(reader.value()->readRows(2, "id", 0, 1, out).code(), StatusCode::kNotFound);
  auto grid = reader.value()->readGrid(1);
  ASSERT_TRUE(grid) << grid.status().toString();
  ASSERT_TRUE(reader.value()->readGridRows(1, kMeanVelocityName, 1, 1, out));
  const std::size_t slab = std::size_t(grid->spec.cells[1]) * grid->spec.cells[2] * 3;
  ASSERT_EQ(out.size(), slab * sizeof(double));
  EXPECT_EQ(std::memcmp(out.data(), grid->meanVelocity.data() + slab, out.size()), 0);
  // The old whole-snapshot read still works and ignores the grid group.
  auto whole = reader.value()->read(1);
  ASSERT_TRUE(whole);
  EXPECT_EQ(whole->arrays.size(), s.arrays.size());
}

TEST_F(StoreTest, AbortAndFailedCommitLeaveNothing) {
  const auto s = makeSnapshot(5, 2000);
  {
    auto ingest = st->beginSnapshot("j", 5, s.time, s.n);
    ASSERT_TRUE(ingest);
    ASSERT_TRUE(sendAll(*ingest.value(), "j", s, nullptr));
    EXPECT_EQ(scratchFiles(), 1u);
    ingest.value()->abort();
    EXPECT_EQ(scratchFiles(), 0u);
  }
  EXPECT_EQ(st->list("j").status().code(), StatusCode::kNotFound);  // nothing stored: still unknown
  {
    // Dropped without commit (a cancelled stream).
    auto ingest = st->beginSnapshot("j", 5, s.time, s.n);
    ASSERT_TRUE(ingest);
    Chunk c{"j", 5, s.time, s.n, Section::kParticles, {}, std::nullopt};
    ASSERT_TRUE(particlePieces(s.arrays[0], s.n, [&](ArrayPiece&& p) {
      c.array = std::move(p);
      return ingest.value()->appendChunk(c);
    }));
  }
  EXPECT_EQ(scratchFiles(), 0u);
  {
    // Incomplete: the first of several pieces of position.
    const auto big = makeSnapshot(5, 60000);
    auto ingest = st->beginSnapshot("j", 5, big.time, big.n);
    ASSERT_TRUE(ingest);
    bool firstOnly = true;
    ASSERT_TRUE(particlePieces(big.arrays[0], big.n, [&](ArrayPiece&& p) {
      if (!firstOnly) return Status::ok();
      firstOnly = false;
      return ingest.value()->appendChunk({"j", 5, big.time, big.n, Section::kParticles, std::move(p), std::nullopt});
    }));
    auto r = ingest.value()->commit();
    ASSERT_FALSE(r);
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(r.status().message().find("incomplete"), std::string::npos) << r.status().message();
  }
  EXPECT_EQ(scratchFiles(), 0u);
  ASSERT_TRUE(store(*st, "j", s));  // the step is free again
  auto listing = st->list("j");
  ASSERT_TRUE(listing);
  EXPECT_EQ(listing->snapshots.size(), 1u);
}

std::size_t openDescriptors() {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator("/proc/self/fd")) ++n;
  return n;
}

// Job files are closed once more than StoreOptions::maxOpenJobFiles are open (the least recently used first) and
// opened again on demand: over 2,000 jobs the back-end's descriptors stay bounded (it ran out after about a
// thousand jobs when every job file stayed open), and every job is still listed and read back.
TEST_F(StoreTest, OpenJobFilesStayBoundedOverManyJobs) {
  st.reset();
  StoreOptions o{dir.string(), 0.0};
  o.maxOpenJobFiles = 8;
  auto opened = SnapshotStore::open(o);
  ASSERT_TRUE(opened) << opened.status().toString();
  st = std::move(opened.value());
  const ParticleSnapshot s = makeSnapshot(1, 4);
  const std::size_t before = openDescriptors();
  std::size_t most = before;
  constexpr int kJobs = 2000;
  for (int k = 0; k < kJobs; ++k) {
    auto r = store(*st, "job" + std::to_string(k), s);
    ASSERT_TRUE(r) << k << ": " << r.status().toString();
    most = std::max(most, openDescriptors());
  }
  EXPECT_LE(most, before + 8 + 2) << "descriptors grew from " << before << " to " << most;
  for (int k : {0, 1, 977, kJobs - 1}) {  // closed long ago or just now: listed and read back alike
    auto l = st->list("job" + std::to_string(k));
    ASSERT_TRUE(l) << l.status().toString();
    EXPECT_EQ(l.value().snapshots.size(), 1u);
    auto rb = readBack(*st, "job" + std::to_string(k), {});
    ASSERT_TRUE(rb) << rb.status().toString();
    EXPECT_EQ(rb.value().particles["position"], bytesOf(*s.find("position")));
  }
  EXPECT_LE(openDescriptors(), before + 8 + 2);
}

// The free-space check before a commit, on any machine (the file system's free bytes replaced): a snapshot that
// would leave less than the reserve is refused with RESOURCE_EXHAUSTED (which the worker waits out), the job file
// and the scratch folder untouched; once there is room, the same step is stored.
TEST_F(StoreTest, CommitRefusedWhenTheDiskWouldFill) {
  st.reset();
  std::uint64_t free = std::uint64_t(1) << 40;
  StoreOptions o{dir.string(), 0.0};
  o.reserveBytes = 1 << 20;
  o.freeBytes = [&free](const std::string&) { return free; };
  auto opened = SnapshotStore::open(o);
  ASSERT_TRUE(opened) << opened.status().toString();
  st = std::move(opened.value());
  ASSERT_TRUE(store(*st, "j", makeSnapshot(1, 1000)));
  free = (1 << 20) + 1000;  // the reserve and a little: not the snapshot's 64 kB
  auto refused = store(*st, "j", makeSnapshot(2, 1000));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted) << refused.status().toString();
  EXPECT_NE(refused.status().message().find("refused, nothing written"), std::string::npos) << refused.status().toString();
  EXPECT_EQ(scratchFiles(), 0u);
  EXPECT_EQ(st->list("j").value().snapshots.size(), 1u);
  free = std::uint64_t(1) << 40;
  ASSERT_TRUE(store(*st, "j", makeSnapshot(2, 1000)));
  EXPECT_EQ(st->list("j").value().snapshots.size(), 2u);
}

// A data directory on a small file system (a 3 MiB tmpfs, mounted where the test may: root; skipped elsewhere) fills
// up: the commit that does not fit is refused with a clear error (never a crash), leaves no scratch file, and every
// snapshot stored before it still reads back.
TEST_F(StoreTest, FullDiskRefusesTheSnapshotAndKeepsTheRest) {
  st.reset();
  fs::create_directories(dir);
  if (::geteuid() != 0 || std::system(("mount -t tmpfs -o size=3m tmpfs " + dir.string() + " 2>/dev/null").c_str()) != 0)
    GTEST_SKIP() << "cannot mount a small tmpfs here (needs root)";
  struct Unmount {
    std::string at;
    ~Unmount() { (void)std::system(("umount " + at).c_str()); }
  } unmount{dir.string()};
  StoreOptions o{dir.string(), 0.0};
  o.reserveBytes = 256 << 10;  // a small disk: keep a quarter MiB
  auto opened = SnapshotStore::open(o);
  ASSERT_TRUE(opened) << opened.status().toString();
  st = std::move(opened.value());
  std::int64_t step = 0;
  Status refused;
  for (; step < 100; ++step) {
    auto r = store(*st, "full", makeSnapshot(step, 4000));  // about 0.3 MB each
    if (!r) {
      refused = r.status();
      break;
    }
  }
  ASSERT_FALSE(refused.isOk()) << "3 MiB never filled";
  EXPECT_TRUE(refused.code() == StatusCode::kResourceExhausted || refused.code() == StatusCode::kIo) << refused.toString();
  EXPECT_NE(refused.message().find("step " + std::to_string(step)), std::string::npos) << refused.toString();
  std::printf("refused at step %lld: %s\n", (long long)step, refused.toString().c_str());
  EXPECT_EQ(scratchFiles(), 0u);
  // The disk full already while the snapshot arrives (its scratch file cannot be written): a clean error too.
  {
    std::ofstream filler(dir / "filler", std::ios::binary);
    const std::vector<char> block(64 << 10, 'x');
    while (filler.write(block.data(), std::streamsize(block.size())) && filler.flush()) {
    }
  }
  auto r = store(*st, "full", makeSnapshot(step, 4000));
  ASSERT_FALSE(r) << "stored on a full disk";
  EXPECT_TRUE(r.status().code() == StatusCode::kResourceExhausted || r.status().code() == StatusCode::kIo) << r.status().toString();
  std::printf("full disk while receiving: %s\n", r.status().toString().c_str());
  EXPECT_EQ(scratchFiles(), 0u);
  fs::remove(dir / "filler");
  auto l = st->list("full");
  ASSERT_TRUE(l) << l.status().toString();
  EXPECT_EQ(l.value().snapshots.size(), std::size_t(step));
  for (std::int64_t k = 0; k < step; ++k) {
    ReadRequest q;
    q.step = k;
    auto rb = readBack(*st, "full", q);
    ASSERT_TRUE(rb) << k << ": " << rb.status().toString();
    EXPECT_EQ(rb.value().particles["position"], bytesOf(*makeSnapshot(k, 4000).find("position"))) << k;
  }
  st.reset();
}

TEST_F(StoreTest, BadInputs) {
  const auto s = makeSnapshot(3, 10);
  for (const char* bad : {"", "../x", "a/b", ".hidden", "a b"})
    EXPECT_EQ(st->beginSnapshot(bad, 1, 0, 1).status().code(), StatusCode::kInvalidArgument) << bad;
  EXPECT_EQ(st->list("nobody").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(st->openRead("nobody", {}).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(st->beginSnapshot("j", 1, std::nan(""), 1).status().code(), StatusCode::kInvalidArgument);

  ASSERT_TRUE(store(*st, "j", s));
  // Written twice: at begin ALREADY_EXISTS; two streams racing for one step: UNAVAILABLE for the second (not
  // "already stored": a worker's retry must not count the snapshot delivered while the first try may still fail).
  EXPECT_EQ(st->beginSnapshot("j", 3, 0, 10).status().code(), StatusCode::kAlreadyExists);
  auto a = st->beginSnapshot("j", 4, 0, 10);
  ASSERT_TRUE(a);
  EXPECT_EQ(st->beginSnapshot("j", 4, 0, 10).status().code(), StatusCode::kUnavailable);
  a.value()->abort();

  auto missing = st->openRead("j", {99, {}, false, false});
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("step 99"), std::string::npos);
  auto field = st->openRead("j", {3, {"pressure"}, false, false});
  ASSERT_FALSE(field);
  EXPECT_EQ(field.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(field.status().message().find("it has: position"), std::string::npos) << field.status().message();

  // Chunks that do not fit together.
  auto ingest = st->beginSnapshot("j", 7, 0.5, 10);
  ASSERT_TRUE(ingest);
  auto& in = *ingest.value();
  auto piece = [&](std::uint64_t first, std::uint64_t rows, std::vector<std::uint64_t> shape) {
    ArrayPiece p{"position", DType::kF64, std::move(shape), first, rows, "m", std::string(rows * 24, '\0')};
    return p;
  };
  EXPECT_EQ(in.appendChunk({"j", 8, 0.5, 10, Section::kParticles, piece(0, 5, {10, 3}), {}}).code(),
            StatusCode::kInvalidArgument);  // other step
  EXPECT_EQ(in.appendChunk({"k", 7, 0.5, 10, Section::kParticles, piece(0, 5, {10, 3}), {}}).code(),
            StatusCode::kInvalidArgument);  // other job
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 11, Section::kParticles, piece(0, 5, {10, 3}), {}}).code(),
            StatusCode::kInvalidArgument);  // other n
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, piece(0, 5, {9, 3}), {}}).code(),
            StatusCode::kInvalidArgument);  // shape not n rows
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, piece(5, 5, {10, 3}), {}}).code(),
            StatusCode::kInvalidArgument);  // gap
  ASSERT_TRUE(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, piece(0, 5, {10, 3}), {}}));
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, piece(3, 5, {10, 3}), {}}).code(),
            StatusCode::kInvalidArgument);  // overlap
  auto shortData = piece(5, 5, {10, 3});
  shortData.data.pop_back();
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, shortData, {}}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, piece(5, 6, {10, 3}), {}}).code(),
            StatusCode::kInvalidArgument);  // past the end
  auto i64 = piece(0, 10, {10});
  i64.name = "x";
  i64.dtype = DType::kI64;
  i64.data.resize(80);
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, i64, {}}).code(), StatusCode::kInvalidArgument);
  auto geo = piece(0, 1, {1, 3});
  geo.name = "walls";
  EXPECT_EQ(in.appendChunk({"j", 7, 0.5, 10, Section::kGeometry, geo, {}}).code(), StatusCode::kInvalidArgument);
  ASSERT_TRUE(in.appendChunk({"j", 7, 0.5, 10, Section::kParticles, piece(5, 5, {10, 3}), {}}));
  // Only position, no velocity/radius: stored without a grid.
  auto r = in.commit();
  ASSERT_TRUE(r) << r.status().toString();
  EXPECT_FALSE(r->grid.has_value());

  // No position at all.
  auto noPos = st->beginSnapshot("j", 9, 0, 2);
  ASSERT_TRUE(noPos);
  ASSERT_TRUE(noPos.value()->appendChunk(
      {"j", 9, 0, 2, Section::kParticles, {"radius", DType::kF64, {2}, 0, 2, "m", std::string(16, '\0')}, {}}));
  auto c = noPos.value()->commit();
  ASSERT_FALSE(c);
  EXPECT_NE(c.status().message().find("position"), std::string::npos);
  EXPECT_EQ(scratchFiles(), 0u);
}

TEST_F(StoreTest, ReopenedStoreAppendsToTheJobFile) {
  ASSERT_TRUE(store(*st, "j", makeSnapshot(1, 100), nullptr));
  const auto geometry = makeGeometry();
  ASSERT_TRUE(store(*st, "j", makeSnapshot(2, 100), &geometry));
  st.reset();
  auto again = SnapshotStore::open({dir.string(), 1e-2});
  ASSERT_TRUE(again);
  st = std::move(again.value());
  EXPECT_EQ(st->beginSnapshot("j", 2, 0, 1).status().code(), StatusCode::kAlreadyExists);
  auto c = store(*st, "j", makeSnapshot(3, 100), &geometry);  // the geometry is stored once
  ASSERT_TRUE(c) << c.status().toString();
  EXPECT_DOUBLE_EQ(c->grid->cellSize, 1e-2);
  auto listing = st->list("j");
  ASSERT_TRUE(listing);
  ASSERT_EQ(listing->snapshots.size(), 3u);
  auto reader = SnapshotReader::open((dir / "j.h5").string());
  ASSERT_TRUE(reader);
  auto g = reader.value()->readGeometry();
  ASSERT_TRUE(g);
  EXPECT_EQ(g->surfaceNames, geometry.surfaceNames);
  EXPECT_EQ(g->planeNames, geometry.planeNames);
  std::ifstream xmf(dir / "j.xmf");
  std::stringstream text;
  text << xmf.rdbuf();
  for (const char* step : {"/snapshots/1/position", "/snapshots/2/position", "/snapshots/3/position"})
    EXPECT_NE(text.str().find(step), std::string::npos) << step;
}

TEST_F(StoreTest, EmptySnapshot) {
  ParticleSnapshot s;
  s.step = 0;
  s.arrays = {makeArray<double>("position", ScalarType::kF64, 3, "m", {}),
              makeArray<double>("radius", ScalarType::kF64, 1, "m", {})};
  auto c = store(*st, "j", s);
  ASSERT_TRUE(c) << c.status().toString();
  auto rb = readBack(*st, "j", {0, {}, true, false});
  ASSERT_TRUE(rb);
  EXPECT_EQ(rb->order, (std::vector<std::string>{"position", "radius"}));
  EXPECT_EQ(rb->shapes["position"], (std::vector<std::uint64_t>{0, 3}));
}

}  // namespace
}  // namespace pflow::backend
