// SnapshotService over real sockets (127.0.0.1, port 0): client round trip bit for bit, errors, cancellation, and
// the server's memory while streaming a 10^6-particle snapshot (pflow-backend as a child process).
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

#include "backend/BackendClient.h"
#include "backend/ChunkProto.h"
#include "backend/SnapshotService.h"
#include "common/rpc/Rpc.h"

extern char** environ;

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

// n particles on a cubic lattice (side m), 7 arrays like a pflow run's snapshot: ~116 bytes per particle.
ParticleSnapshot makeSnapshot(std::int64_t step, std::size_t n) {
  ParticleSnapshot s;
  s.step = step;
  s.time = 2.5e-4 * double(step);
  s.n = n;
  std::size_t m = 1;
  while (m * m * m < n) ++m;
  std::vector<double> x(3 * n), v(3 * n), w(3 * n), f(3 * n), r(n);
  std::vector<std::uint64_t> id(n);
  std::vector<std::int32_t> material(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double d = 1.1e-3;
    x[3 * i] = d * double(i % m);
    x[3 * i + 1] = d * double((i / m) % m);
    x[3 * i + 2] = d * double(i / (m * m));
    for (int c = 0; c < 3; ++c) {
      v[3 * i + c] = std::sin(0.001 * double(i) + c);
      w[3 * i + c] = 10.0 * std::cos(0.002 * double(i) + c);
      f[3 * i + c] = 1e-3 * double(i % 97) - c;
    }
    r[i] = 0.5e-3 * (1.0 + 0.01 * double(i % 7));
    id[i] = (std::uint64_t(1) << 40) + i;
    material[i] = int(i % 3);
  }
  s.arrays = {makeArray("position", ScalarType::kF64, 3, "m", x),
              makeArray("velocity", ScalarType::kF64, 3, "m/s", v),
              makeArray("angular_velocity", ScalarType::kF64, 3, "rad/s", w),
              makeArray("force", ScalarType::kF64, 3, "N", f),
              makeArray("radius", ScalarType::kF64, 1, "m", r),
              makeArray("material", ScalarType::kI32, 1, "", material),
              makeArray("id", ScalarType::kU64, 1, "", id)};
  return s;
}

GeometrySnapshot makeGeometry() {
  GeometrySnapshot g;
  g.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  g.triangles = {0, 1, 2, 1, 3, 2};
  g.triangleMesh = {0, 0};
  g.triangleSurface = {1, 1};
  g.triangleMaterial = {0, 0};
  g.meshNames = {"floor"};
  g.planePoints = {{0, 0, -1}};
  g.planeNormals = {{0, 0, 1}};
  g.planeMaterial = {0};
  g.planeNames = {"ground"};
  g.planeSurface = {0};
  g.surfaceNames = {"ground", "floor"};
  return g;
}

void expectSameArrays(const ParticleSnapshot& a, const ParticleSnapshot& b) {
  EXPECT_EQ(a.step, b.step);
  EXPECT_EQ(a.time, b.time);
  ASSERT_EQ(a.n, b.n);
  ASSERT_EQ(a.arrays.size(), b.arrays.size());
  for (std::size_t i = 0; i < a.arrays.size(); ++i) {
    EXPECT_EQ(a.arrays[i].name, b.arrays[i].name);
    EXPECT_EQ(a.arrays[i].type, b.arrays[i].type);
    EXPECT_EQ(a.arrays[i].components, b.arrays[i].components);
    EXPECT_EQ(a.arrays[i].unit, b.arrays[i].unit);
    EXPECT_TRUE(a.arrays[i].data == b.arrays[i].data) << a.arrays[i].name << " differs";
  }
}

fs::path tempDir(const std::string& what) {
  auto d = fs::temp_directory_path() / ("pflow_svc_" + std::to_string(::getpid()) + "_" + what);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = tempDir(::testing::UnitTest::GetInstance()->current_test_info()->name());
    auto s = SnapshotStore::open({(dir / "data").string(), 0.0});
    ASSERT_TRUE(s);
    store = std::move(s.value());
    service = std::make_unique<SnapshotService>(*store);
    auto server = rpc::ServerRunner::start("127.0.0.1:0", {service.get()});
    ASSERT_TRUE(server) << server.status().toString();
    runner = std::move(server.value());
    channel = rpc::makeChannel(runner->address());
    client = makeGrpcBackendClient(channel);
  }
  void TearDown() override {
    client.reset();
    runner.reset();
    service.reset();
    store.reset();
    fs::remove_all(dir);
  }
  std::size_t scratchFiles() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / "data" / ".ingest")) ++n;
    return n;
  }

  fs::path dir;
  std::unique_ptr<SnapshotStore> store;
  std::unique_ptr<SnapshotService> service;
  std::unique_ptr<rpc::ServerRunner> runner;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<BackendClient> client;
};

TEST_F(ServiceTest, WriteListFetchBitForBit) {
  const auto s = makeSnapshot(100, 50000);
  const auto geometry = makeGeometry();
  ASSERT_TRUE(client->writeSnapshot("run-a", s, &geometry));
  ASSERT_TRUE(client->writeSnapshot("run-a", makeSnapshot(200, 10), nullptr));
  auto listing = client->list("run-a");
  ASSERT_TRUE(listing) << listing.status().toString();
  ASSERT_EQ(listing->size(), 2u);
  EXPECT_EQ((*listing)[0].step, 100);
  EXPECT_EQ((*listing)[0].particles, 50000u);
  EXPECT_EQ((*listing)[0].time, s.time);

  const std::string out = (dir / "fetched.h5").string();
  ASSERT_TRUE(client->fetch("run-a", 100, out, {}, true, true));
  EXPECT_TRUE(fs::exists(dir / "fetched.xmf"));
  EXPECT_FALSE(fs::exists(out + ".part"));
  auto reader = SnapshotReader::open(out);
  ASSERT_TRUE(reader) << reader.status().toString();
  auto back = reader.value()->read(100);
  ASSERT_TRUE(back);
  expectSameArrays(s, back.value());
  auto geo = reader.value()->readGeometry();
  ASSERT_TRUE(geo);
  EXPECT_EQ(geo->triangles, geometry.triangles);
  EXPECT_EQ(geo->surfaceNames, geometry.surfaceNames);
  EXPECT_EQ(geo->planeNames, geometry.planeNames);
  EXPECT_EQ(geo->vertices.size(), geometry.vertices.size());
  // The grid arrives as the back-end stored it.
  auto grid = reader.value()->readGrid(100);
  ASSERT_TRUE(grid) << grid.status().toString();
  auto stored = SnapshotReader::open(store->jobFile("run-a"));
  ASSERT_TRUE(stored);
  auto storedGrid = stored.value()->readGrid(100);
  ASSERT_TRUE(storedGrid);
  EXPECT_EQ(grid->spec.cells, storedGrid->spec.cells);
  EXPECT_TRUE(grid->solidFraction == storedGrid->solidFraction);
  EXPECT_TRUE(grid->meanVelocity == storedGrid->meanVelocity);
  EXPECT_TRUE(grid->granularTemperature == storedGrid->granularTemperature);

  // The last step, two fields, no grid.
  const std::string out2 = (dir / "last.h5").string();
  ASSERT_TRUE(client->fetch("run-a", std::nullopt, out2, {"id", "position"}, false, false));
  auto r2 = SnapshotReader::open(out2);
  ASSERT_TRUE(r2);
  EXPECT_EQ(r2.value()->steps(), (std::vector<std::int64_t>{200}));
  auto last = r2.value()->read(200);
  ASSERT_TRUE(last);
  ASSERT_EQ(last->arrays.size(), 2u);
  EXPECT_EQ(last->arrays[0].name, "id");
  EXPECT_FALSE(r2.value()->hasGeometry());
  EXPECT_FALSE(r2.value()->readGrid(200));
}

TEST_F(ServiceTest, Errors) {
  const auto s = makeSnapshot(1, 100);
  auto unknown = client->list("nobody");
  EXPECT_EQ(unknown.status().code(), StatusCode::kNotFound);
  EXPECT_NE(unknown.status().message().find("nobody"), std::string::npos);
  const std::string out = (dir / "x.h5").string();
  EXPECT_EQ(client->fetch("nobody", std::nullopt, out, {}, false, false).code(), StatusCode::kNotFound);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out + ".part"));
  EXPECT_EQ(client->writeSnapshot("../etc", s, nullptr).code(), StatusCode::kInvalidArgument);

  ASSERT_TRUE(client->writeSnapshot("j", s, nullptr));
  auto twice = client->writeSnapshot("j", s, nullptr);
  EXPECT_EQ(twice.code(), StatusCode::kAlreadyExists);
  EXPECT_NE(twice.message().find("step 1"), std::string::npos) << twice.message();
  auto noStep = client->fetch("j", 7, out, {}, false, false);
  EXPECT_EQ(noStep.code(), StatusCode::kNotFound);
  EXPECT_NE(noStep.message().find("step 7"), std::string::npos) << noStep.message();
  auto noField = client->fetch("j", 1, out, {"pressure"}, false, false);
  EXPECT_EQ(noField.code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(out));
  auto listing = client->list("j");
  ASSERT_TRUE(listing);
  EXPECT_EQ(listing->size(), 1u);
  EXPECT_EQ(scratchFiles(), 0u);
}

// Raw stubs: malformed chunks and a cancelled stream leave no snapshot behind.
TEST_F(ServiceTest, MalformedAndCancelledStreams) {
  auto stub = v1::SnapshotService::NewStub(channel);
  const auto s = makeSnapshot(3, 60000);
  {
    auto ctx = rpc::contextWithDeadline(10);
    v1::WriteSnapshotResponse response;
    auto writer = stub->WriteSnapshot(ctx.get(), &response);
    v1::SnapshotChunk m;
    m.set_job_id("j");
    m.set_step(3);
    m.mutable_array()->set_name("position");  // no section, no dtype
    writer->Write(m);
    writer->WritesDone();
    const auto st = writer->Finish();
    EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(st.error_message().find("no section"), std::string::npos) << st.error_message();
  }
  {
    // Pieces of position out of order.
    auto ctx = rpc::contextWithDeadline(10);
    v1::WriteSnapshotResponse response;
    auto writer = stub->WriteSnapshot(ctx.get(), &response);
    std::vector<Chunk> chunks;
    ASSERT_TRUE(snapshotChunks("j", s, nullptr, [&](Chunk&& c) {
      if (chunks.size() < 2) chunks.push_back(std::move(c));
      return Status::ok();
    }));
    v1::SnapshotChunk m;
    chunkToProto(std::move(chunks[1]), &m);
    writer->Write(m);
    writer->WritesDone();
    const auto st = writer->Finish();
    EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(st.error_message().find("expected row 0"), std::string::npos) << st.error_message();
  }
  {
    // Cancelled after a few chunks, before the half-close.
    auto ctx = rpc::contextWithDeadline(10);
    v1::WriteSnapshotResponse response;
    auto writer = stub->WriteSnapshot(ctx.get(), &response);
    int sent = 0;
    (void)snapshotChunks("j", s, nullptr, [&](Chunk&& c) {
      if (sent++ >= 3) return Status(StatusCode::kCancelled, "enough");
      v1::SnapshotChunk m;
      chunkToProto(std::move(c), &m);
      writer->Write(m);
      return Status::ok();
    });
    ctx->TryCancel();
    EXPECT_EQ(writer->Finish().error_code(), grpc::StatusCode::CANCELLED);
  }
  // The server finishes its side asynchronously (its reactor learns of the cancel on its own thread, later
  // under load): wait for the scratch file to go, up to the stream's deadline.
  for (int i = 0; i < 500 && scratchFiles() > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(scratchFiles(), 0u);
  EXPECT_EQ(client->list("j").status().code(), StatusCode::kNotFound);
  // The step was never taken: it can be written now. Under load the cancelled stream's reactor may not even have
  // made its scratch file yet when the loop above looked, and then still holds the step: the server says
  // UNAVAILABLE, "try again", and a retry within the stream's deadline succeeds.
  Status written = client->writeSnapshot("j", s, nullptr);
  for (int i = 0; i < 500 && written.code() == StatusCode::kUnavailable; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    written = client->writeSnapshot("j", s, nullptr);
  }
  ASSERT_TRUE(written.isOk()) << written.toString();
}

// --- memory: pflow-backend as a child process ---------------------------------------------------------------------

long statusKb(pid_t pid, const char* key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::stol(line.substr(std::strlen(key) + 1));
  return -1;
}

// An SPH job's probe series: appended in two calls (the first one more than 1 MiB, so cut into several
// requests), stored in /probes of the job's file, fetched with a snapshot into /probes and the CSV beside it;
// probes that differ from the stored ones are refused.
TEST_F(ServiceTest, ProbeSeriesAppendAndFetch) {
  ASSERT_TRUE(client->writeSnapshot("sph-a", makeSnapshot(0, 10), nullptr));
  ProbeSeries first;
  first.names = {"P1", "H1"};
  first.units = {"Pa", "m"};
  first.points = {{0.8, 0.47, 0.02}, {0.5, 0.5, 0}};
  for (int i = 0; i < 50000; ++i) first.add(1e-4 * i, {100.0 * i, 1e-3 * i});  // 1.2 MB of values with the times
  ASSERT_TRUE(client->appendProbes("sph-a", first));
  ProbeSeries second = probeSamples(first, first.time.size());
  second.add(5.0, {1.0, 2.0});
  ASSERT_TRUE(client->appendProbes("sph-a", second));
  auto requests = probesToProto("sph-a", first);
  ASSERT_TRUE(requests);
  EXPECT_GE(requests->size(), 2u);
  for (const auto& r : requests.value()) EXPECT_LE(r.time().size() + r.values().size(), kMaxChunkBytes);

  const std::string out = (dir / "sph.h5").string();
  ASSERT_TRUE(client->fetch("sph-a", std::nullopt, out, {}, false, false, true));
  auto back = readProbeSeries(out);
  ASSERT_TRUE(back) << back.status().toString();
  EXPECT_EQ(back->names, first.names);
  EXPECT_EQ(back->units, first.units);
  EXPECT_EQ(back->points[0].y, 0.47);
  ASSERT_EQ(back->time.size(), 50001u);
  EXPECT_EQ(back->time.back(), 5.0);
  EXPECT_EQ(back->values[0][49999], 100.0 * 49999);
  EXPECT_EQ(back->values[1].back(), 2.0);
  std::ifstream csv(probesCsvPathFor(out));
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header, "time [s],P1 [Pa],H1 [m]");

  // A fetch without probes leaves them out; other probes are refused with the reason.
  const std::string plain = (dir / "plain.h5").string();
  ASSERT_TRUE(client->fetch("sph-a", std::nullopt, plain, {}, false, false, false));
  EXPECT_FALSE(readProbeSeries(plain));
  ProbeSeries other = second;
  other.names = {"P2", "H1"};
  const Status refused = client->appendProbes("sph-a", other);
  EXPECT_EQ(refused.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(refused.message().find("not the ones in /probes"), std::string::npos) << refused.message();
}

struct Child {
  pid_t pid = -1;
  int port = 0;
};

Child startBackend(const fs::path& data, const fs::path& portFile) {
  fs::remove(portFile);
  std::vector<std::string> args = {PFLOW_BACKEND_EXE, "--insecure", "--listen", "127.0.0.1:0", "--data", data.string(),
                                   "--port-file", portFile.string(), "--log-level", "warn"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  Child c;
  if (posix_spawn(&c.pid, PFLOW_BACKEND_EXE, nullptr, nullptr, argv.data(), environ) != 0) return {};
  for (int i = 0; i < 200 && !fs::exists(portFile); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(25));
  std::ifstream(portFile) >> c.port;
  return c;
}

void stopBackend(Child& c) {
  if (c.pid <= 0) return;
  kill(c.pid, SIGTERM);
  int status = 0;
  waitpid(c.pid, &status, 0);
  c.pid = -1;
}

TEST(ServiceMemory, FetchOfAMillionParticlesStreamsInBoundedMemory) {
  const fs::path dir = tempDir("memory");
  const fs::path data = dir / "data", portFile = dir / "port";
  const std::size_t n = 1000000;
  std::size_t snapshotBytes = 0;
  long ingestHwmKb = 0, ingestBaseKb = 0;
  {
    const auto s = makeSnapshot(42, n);
    for (const auto& a : s.arrays) snapshotBytes += a.data.size();
    Child a = startBackend(data, portFile);
    ASSERT_GT(a.port, 0);
    auto client = makeGrpcBackendClient("127.0.0.1:" + std::to_string(a.port));
    ASSERT_TRUE(client->list("warmup").status().code() == StatusCode::kNotFound);
    ingestBaseKb = statusKb(a.pid, "VmRSS:");
    const auto t0 = std::chrono::steady_clock::now();
    Status st = client->writeSnapshot("big", s, nullptr);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ingestHwmKb = statusKb(a.pid, "VmHWM:");
    stopBackend(a);
    ASSERT_TRUE(st) << st.toString();
    std::cout << "[memory] ingest of " << n << " particles (" << snapshotBytes / 1e6 << " MB) took " << seconds
              << " s; server RSS before " << ingestBaseKb / 1024.0 << " MiB, peak " << ingestHwmKb / 1024.0
              << " MiB\n";
  }
  // A fresh server (no heap left over from the ingest) streams the snapshot back.
  Child b = startBackend(data, portFile);
  ASSERT_GT(b.port, 0);
  auto client = makeGrpcBackendClient("127.0.0.1:" + std::to_string(b.port));
  auto listing = client->list("big");
  ASSERT_TRUE(listing);
  ASSERT_EQ(listing->size(), 1u);
  EXPECT_EQ((*listing)[0].particles, n);
  const long baseKb = statusKb(b.pid, "VmRSS:");
  std::ofstream(("/proc/" + std::to_string(b.pid) + "/clear_refs").c_str()) << "5";  // reset VmHWM to VmRSS
  const std::string out = (dir / "fetched.h5").string();
  const auto t0 = std::chrono::steady_clock::now();
  Status st = client->fetch("big", 42, out, {}, true, false);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const long hwmKb = statusKb(b.pid, "VmHWM:");
  stopBackend(b);
  ASSERT_TRUE(st) << st.toString();
  const double growthMiB = (hwmKb - baseKb) / 1024.0;
  std::cout << "[memory] fetch of " << snapshotBytes / 1e6 << " MB took " << seconds << " s; server RSS before "
            << baseKb / 1024.0 << " MiB, peak during fetch " << hwmKb / 1024.0 << " MiB, growth " << growthMiB
            << " MiB\n";
  ::testing::Test::RecordProperty("fetch_rss_growth_mib", std::to_string(growthMiB));
  ::testing::Test::RecordProperty("ingest_peak_rss_mib", std::to_string(ingestHwmKb / 1024.0));
  EXPECT_LT(growthMiB, 32.0) << "the back-end's memory grew by " << growthMiB << " MiB for a "
                             << snapshotBytes / 1048576.0 << " MiB snapshot";
  // And the data arrived intact.
  auto reader = SnapshotReader::open(out);
  ASSERT_TRUE(reader);
  auto back = reader.value()->read(42);
  ASSERT_TRUE(back);
  expectSameArrays(makeSnapshot(42, n), back.value());
  EXPECT_TRUE(reader.value()->readGrid(42));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace pflow::backend
