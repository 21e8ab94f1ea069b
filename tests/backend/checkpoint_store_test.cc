// The back-end's checkpoint store (backend/CheckpointStore.h): uploads in chunks kept only once they read back as a
// checkpoint of the step announced, the last two kept, damaged or partial uploads never kept, a full disk refused,
// the one before sent when the last does not read; and the probe series of a resumed run not doubled.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include "backend/BackendClient.h"
#include "backend/SnapshotStore.h"
#include "backend/store/CheckpointFile.h"

namespace pflow::backend {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("pflow-ckpt-store-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// A small checkpoint file of `step` (n particles, one position array).
std::string checkpointFile(const fs::path& dir, std::int64_t step, std::size_t n = 100) {
  CheckpointData d;
  d.solver = "dem";
  d.precision = "double";
  d.sceneText = "solver: dem\n";
  d.state.step = step;
  d.state.time = 1e-5 * double(step);
  d.state.particles.n = n;
  compute::SnapshotArray a{"position", compute::ScalarType::kF64, 3, "m", {}};
  a.data.resize(n * 3 * sizeof(double));
  auto* p = a.as<double>();
  for (std::size_t i = 0; i < 3 * n; ++i) p[i] = 1e-3 * double(i) + double(step);
  d.state.particles.arrays.push_back(std::move(a));
  const std::string path = (dir / ("local-" + std::to_string(step) + ".h5")).string();
  EXPECT_TRUE(writeCheckpoint(path, d).isOk());
  return path;
}

std::vector<char> bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Uploads `bytes` as checkpoint `step` of `job` in chunks of `chunk` bytes.
Result<StoredCheckpoint> upload(CheckpointStore& store, const std::string& job, std::int64_t step, const std::vector<char>& bytes,
                                std::size_t chunk = 1000) {
  auto u = store.begin(job, step, bytes.size());
  if (!u) return u.status();
  for (std::size_t off = 0; off < bytes.size(); off += chunk)
    PFLOW_TRY(u.value()->append(off, bytes.data() + off, std::min(chunk, bytes.size() - off)));
  return u.value()->commit();
}

// The same content writes the same bytes, a second and more apart (no timestamp in the file, the root group's
// included: until 2026-12-03 its four times made KeepsTheLastTwoAndSendsTheLatest, which writes a checkpoint twice, fail
// when the two writes fell on either side of a second).
TEST(CheckpointFile, TheSameContentWritesTheSameBytes) {
  TempDir t;
  const auto first = bytesOf(checkpointFile(t.path, 300));
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  EXPECT_EQ(bytesOf(checkpointFile(t.path, 300)), first);
}

TEST(CheckpointStore, KeepsTheLastTwoAndSendsTheLatest) {
  TempDir t;
  auto store = CheckpointStore::open({(t.path / "ckpt").string()});
  ASSERT_TRUE(store);
  CheckpointStore& s = *store.value();
  EXPECT_EQ(s.latest("job-1").status().code(), StatusCode::kNotFound);
  auto first = upload(s, "job-1", 100, bytesOf(checkpointFile(t.path, 100)));
  ASSERT_TRUE(first) << first.status().toString();
  EXPECT_EQ(first->step, 100);
  auto second = upload(s, "job-1", 200, bytesOf(checkpointFile(t.path, 200)));
  ASSERT_TRUE(second) << second.status().toString();
  auto third = upload(s, "job-1", 300, bytesOf(checkpointFile(t.path, 300)));
  ASSERT_TRUE(third);
  auto latest = s.latest("job-1");
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->step, 300);
  EXPECT_EQ(bytesOf(latest->path), bytesOf(checkpointFile(t.path, 300)));
  EXPECT_EQ(readCheckpoint(previousCheckpointPath(latest->path))->state.step, 200);  // the one before is kept
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(t.path / "ckpt"))
    if (e.is_regular_file()) ++files;
  EXPECT_EQ(files, 2u);  // and no more
  EXPECT_TRUE(fs::is_empty(t.path / "ckpt" / ".incoming"));
}

TEST(CheckpointStore, NeverKeepsABadUpload) {
  TempDir t;
  auto store = CheckpointStore::open({(t.path / "ckpt").string()});
  ASSERT_TRUE(store);
  CheckpointStore& s = *store.value();
  ASSERT_TRUE(upload(s, "job-1", 100, bytesOf(checkpointFile(t.path, 100))));
  std::vector<char> good = bytesOf(checkpointFile(t.path, 200));
  // Not a checkpoint.
  std::vector<char> junk(good.size(), 'x');
  EXPECT_EQ(upload(s, "job-1", 200, junk).status().code(), StatusCode::kInvalidArgument);
  // Damaged in the middle (HDF5's superblock intact, the data not): refused when its header does not read.
  std::vector<char> cut(good.begin(), good.begin() + std::ptrdiff_t(good.size() / 3));
  auto u = s.begin("job-1", 200, good.size());
  ASSERT_TRUE(u);
  ASSERT_TRUE(u.value()->append(0, cut.data(), cut.size()));
  EXPECT_EQ(u.value()->commit().status().code(), StatusCode::kInvalidArgument) << "incomplete";
  // Announced as another step than it holds.
  auto wrong = upload(s, "job-1", 250, good);
  EXPECT_EQ(wrong.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(wrong.status().message().find("holds step 200"), std::string::npos) << wrong.status().message();
  // Chunks out of order, past the end.
  auto v = s.begin("job-1", 200, good.size());
  ASSERT_TRUE(v);
  EXPECT_EQ(v.value()->append(10, good.data(), 10).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(v.value()->append(0, good.data(), good.size() + 1).code(), StatusCode::kInvalidArgument);
  v.value().reset();
  // Bad job ids, empty files.
  EXPECT_EQ(s.begin("../etc", 1, 10).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.begin("job-1", 1, 0).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.begin("job-1", -1, 10).status().code(), StatusCode::kInvalidArgument);
  // The good one from before is still the latest, and no upload is left behind.
  u.value().reset();
  EXPECT_EQ(s.latest("job-1")->step, 100);
  EXPECT_TRUE(fs::is_empty(t.path / "ckpt" / ".incoming"));
}

TEST(CheckpointStore, AFullDiskIsRefusedBeforeAnyByteIsWritten) {
  TempDir t;
  CheckpointStoreOptions o{(t.path / "ckpt").string()};
  std::uint64_t free = 1 << 20;
  o.reserveBytes = 1 << 19;
  o.freeBytes = [&](const std::string&) { return free; };
  auto store = CheckpointStore::open(o);
  ASSERT_TRUE(store);
  const auto bytes = bytesOf(checkpointFile(t.path, 100, 30000));  // about 720 kB
  ASSERT_GT(bytes.size(), std::size_t(1 << 19));
  auto refused = upload(*store.value(), "job-1", 100, bytes);
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("kept in reserve"), std::string::npos) << refused.status().message();
  free = 16 << 20;
  EXPECT_TRUE(upload(*store.value(), "job-1", 100, bytes));
}

TEST(CheckpointStore, SendsTheOneBeforeWhenTheLastDoesNotRead) {
  TempDir t;
  auto store = CheckpointStore::open({(t.path / "ckpt").string()});
  ASSERT_TRUE(store);
  ASSERT_TRUE(upload(*store.value(), "job-1", 100, bytesOf(checkpointFile(t.path, 100))));
  ASSERT_TRUE(upload(*store.value(), "job-1", 200, bytesOf(checkpointFile(t.path, 200))));
  {  // the disk damages the last one
    std::ofstream out(t.path / "ckpt" / "job-1.h5", std::ios::binary | std::ios::trunc);
    out << "damaged";
  }
  auto latest = store.value()->latest("job-1");
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->step, 100);
  EXPECT_FALSE(latest->skipped.empty());
}

TEST(CheckpointStore, LeftoverUploadsAreRemovedOnOpen) {
  TempDir t;
  fs::create_directories(t.path / "ckpt" / ".incoming");
  std::ofstream(t.path / "ckpt" / ".incoming" / "job-1.7.h5") << "half";
  auto store = CheckpointStore::open({(t.path / "ckpt").string()});
  ASSERT_TRUE(store);
  EXPECT_TRUE(fs::is_empty(t.path / "ckpt" / ".incoming"));
}

// Through the client interface on a SnapshotStore (the worker's calls), and the probe series of a resumed run: the
// samples it sends again (from its checkpoint's time) are not stored twice.
TEST(CheckpointStore, ClientRoundTripAndProbesOfAResumedRun) {
  TempDir t;
  StoreOptions so;
  so.dataDir = (t.path / "data").string();
  auto snapshots = SnapshotStore::open(so);
  ASSERT_TRUE(snapshots);
  LocalBackendClient client(*snapshots.value());
  EXPECT_EQ(client.readCheckpoint("job-1", (t.path / "got.h5").string()).status().code(), StatusCode::kNotFound);
  const std::string sent = checkpointFile(t.path, 400);
  ASSERT_TRUE(client.writeCheckpoint("job-1", 400, sent));
  auto step = client.readCheckpoint("job-1", (t.path / "got.h5").string());
  ASSERT_TRUE(step);
  EXPECT_EQ(step.value(), 400);
  EXPECT_EQ(bytesOf((t.path / "got.h5").string()), bytesOf(sent));

  ProbeSeries a;
  a.names = {"P1"};
  a.units = {"Pa"};
  a.points = {{0, 0, 0}};
  a.time = {0.0, 0.1, 0.2, 0.3};
  a.values = {{1, 2, 3, 4}};
  ASSERT_TRUE(client.appendProbes("job-1", a));
  ProbeSeries again = a;  // resumed at t = 0.2: 0.2 and 0.3 again, then new ones
  again.time = {0.2, 0.3, 0.4};
  again.values = {{3, 4, 5}};
  ASSERT_TRUE(client.appendProbes("job-1", again));
  auto stored = snapshots.value()->appendProbes("job-1", ProbeSeries{{"P1"}, {"Pa"}, {{0, 0, 0}}, {}, {{}}});
  ASSERT_TRUE(stored);
  EXPECT_EQ(stored.value(), 5u);  // 0, 0.1, 0.2, 0.3, 0.4
}

}  // namespace
}  // namespace pflow::backend
