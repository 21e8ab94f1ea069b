// pflow-web's HTTP side against a real manager and back-end in this process (loopback, real gRPC, users with
// tokens): JSON for jobs and nodes, what each user may see, the binary snapshot arrays, the live event stream.
#include <gtest/gtest.h>
#include <httplib.h>

#include <cstring>
#include <thread>

#include "backend/BackendClient.h"
#include "backend/SnapshotService.h"
#include "common/rpc/Rpc.h"
#include "display/ViewerServer.h"
#include "manager/ManagerService.h"
#include "manager/Users.h"
#include "tests/agent/AgentTestUtil.h"
#include "tests/manager/TestManager.h"

namespace pflow::display {
namespace {

using nlohmann::json;

class Viewer : public ::testing::Test {
 protected:
  void SetUp() override {
    m_tm = std::make_unique<manager::testing::TestManager>(manager::testing::TestManager::Options{});
    m_alice = m_tm->addUser("alice");
    m_bob = m_tm->addUser("bob");
    m_manager = m_tm->manager.get();
    ASSERT_TRUE(m_manager->heartbeat(manager::testing::nodeBeat("a", 1)));
    m_job = m_tm->submitAs("alice", 4);
    m_store = backend::SnapshotStore::open({m_dir.path(), 0, 8}).value();
    m_backendService = std::make_unique<backend::SnapshotService>(*m_store);
    m_backendServer = rpc::ServerRunner::start("127.0.0.1:0", {m_backendService.get()}).value();
    m_jobs = makeGrpcJobSource(m_tm->address());
    m_snapshots = makeGrpcSnapshotSource(m_backendServer->address());
    ViewerOptions o;
    o.listen = "127.0.0.1:0";
    m_viewer = ViewerServer::start(o, *m_jobs, *m_snapshots).value();
    m_http = std::make_unique<httplib::Client>("127.0.0.1", m_viewer->port());
  }
  void TearDown() override {
    m_viewer->stop();
    m_backendServer->shutdown(1);
    m_tm.reset();
  }
  httplib::Result get(const std::string& path, const std::string& token) {
    httplib::Headers h;
    if (!token.empty()) h.emplace("Authorization", "Bearer " + token);
    return m_http->Get(path, h);
  }
  // Four particles at step 7, position (i, 2i, 3i) m.
  void storeSnapshot() {
    compute::ParticleSnapshot s;
    s.step = 7;
    s.time = 0.5;
    s.n = 4;
    compute::SnapshotArray pos{"position", compute::ScalarType::kF64, 3, "m", {}};
    pos.data.resize(4 * 3 * 8);
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) pos.as<double>()[3 * i + k] = double(i * (k + 1));
    compute::SnapshotArray id{"id", compute::ScalarType::kU64, 1, "", {}};
    id.data.resize(4 * 8);
    for (int i = 0; i < 4; ++i) id.as<std::uint64_t>()[i] = std::uint64_t(i);
    s.arrays = {pos, id};
    backend::LocalBackendClient local(*m_store);
    ASSERT_TRUE(local.writeSnapshot(m_job, s, nullptr));
  }

  agent::testing::TempDir m_dir;
  std::unique_ptr<manager::testing::TestManager> m_tm;
  manager::Manager* m_manager = nullptr;
  std::string m_alice, m_bob, m_job;
  std::unique_ptr<rpc::ServerRunner> m_backendServer;
  std::unique_ptr<backend::SnapshotStore> m_store;
  std::unique_ptr<backend::SnapshotService> m_backendService;
  std::unique_ptr<JobSource> m_jobs;
  std::unique_ptr<SnapshotSource> m_snapshots;
  std::unique_ptr<ViewerServer> m_viewer;
  std::unique_ptr<httplib::Client> m_http;
};

TEST_F(Viewer, JobsAndNodesAsJsonForTheTokensUser) {
  auto none = get("/api/jobs?all=1", "");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 401);
  EXPECT_EQ(json::parse(none->body)["code"], "UNAUTHENTICATED");
  auto mine = get("/api/jobs?all=1", m_alice);
  ASSERT_TRUE(mine);
  ASSERT_EQ(mine->status, 200) << mine->body;
  const json jobs = json::parse(mine->body);
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_EQ(jobs[0]["id"], m_job);
  EXPECT_EQ(jobs[0]["owner"], "alice");
  EXPECT_EQ(json::parse(get("/api/jobs?all=1", m_bob)->body).size(), 0u);
  EXPECT_EQ(get("/api/jobs/" + m_job, m_bob)->status, 403);
  EXPECT_EQ(get("/api/jobs/job-999999", m_alice)->status, 404);
  auto nodes = get("/api/nodes", m_alice);
  ASSERT_EQ(nodes->status, 200);
  EXPECT_EQ(json::parse(nodes->body)[0]["node"], "a");
  EXPECT_EQ(get("/api/jobs/../../etc/passwd", m_alice)->status, 404);  // no route: ids are [A-Za-z0-9._-]
}

TEST_F(Viewer, SnapshotArraysAsFloat32Frames) {
  EXPECT_EQ(get("/api/jobs/" + m_job + "/snapshots/last", m_alice)->status, 404);  // none yet
  storeSnapshot();
  auto listing = get("/api/jobs/" + m_job + "/snapshots", m_alice);
  ASSERT_EQ(listing->status, 200) << listing->body;
  EXPECT_EQ(json::parse(listing->body)["snapshots"][0]["step"], 7);
  EXPECT_EQ(get("/api/jobs/" + m_job + "/snapshots/last?fields=position", m_bob)->status, 403);

  auto r = get("/api/jobs/" + m_job + "/snapshots/last?fields=position", m_alice);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/x-pflow-arrays");
  // Frames: u32 length, JSON header, float32 values.
  const std::string& b = r->body;
  std::size_t at = 0;
  std::vector<json> headers;
  std::vector<float> positions;
  while (at + 4 <= b.size()) {
    std::uint32_t n = 0;
    for (int i = 0; i < 4; ++i) n |= std::uint32_t(std::uint8_t(b[at + i])) << (8 * i);
    const json h = json::parse(b.substr(at + 4, n));
    at += 4 + n;
    headers.push_back(h);
    if (h.contains("rows")) {
      const std::size_t count = h["rows"].get<std::size_t>() * h["components"].get<std::size_t>();
      std::vector<float> v(count);
      std::memcpy(v.data(), b.data() + at, count * 4);
      at += count * 4;
      if (h["name"] == "position") positions.insert(positions.end(), v.begin(), v.end());
    }
  }
  EXPECT_EQ(at, b.size());
  ASSERT_GE(headers.size(), 2u);
  EXPECT_EQ(headers[0]["step"], 7);
  EXPECT_DOUBLE_EQ(headers[0]["time"].get<double>(), 0.5);
  ASSERT_EQ(positions.size(), 12u);
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(positions[3 * i + k], float(i * (k + 1)));
  EXPECT_EQ(get("/api/jobs/" + m_job + "/snapshots/8", m_alice)->status, 404);
}

TEST_F(Viewer, EventsStreamTheJobUntilItEnds) {
  std::string received;
  std::thread finisher([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ASSERT_TRUE(m_manager->reportExit(m_job, "a", 0, ""));
  });
  auto r = m_http->Get("/api/jobs/" + m_job + "/events?token=" + m_alice, [&](const char* data, std::size_t n) {
    received.append(data, n);
    return true;
  });
  finisher.join();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_NE(received.find("data: "), std::string::npos);
  EXPECT_NE(received.find("\"state\":\"succeeded\""), std::string::npos) << received;  // the stream ended with the job
  std::string denied;
  m_http->Get("/api/jobs/" + m_job + "/events?token=" + m_bob, [&](const char* data, std::size_t n) {
    denied.append(data, n);
    return true;
  });
  EXPECT_NE(denied.find("PERMISSION_DENIED"), std::string::npos) << denied;
}

TEST(ViewerServerStart, PlainHttpServesLoopbackOnly) {
  struct None : JobSource, SnapshotSource {
    Result<json> listJobs(const std::string&, bool) override { return json::array(); }
    Result<json> getJob(const std::string&, const std::string&) override { return json::object(); }
    Result<json> cancelJob(const std::string&, const std::string&) override { return json::object(); }
    Result<json> listNodes(const std::string&) override { return json::array(); }
    Status watchJob(const std::string&, const std::string&, const std::function<bool(const json&)>&) override { return Status::ok(); }
    Result<json> listSnapshots(const std::string&, const std::string&) override { return json::object(); }
    Status readSnapshot(const std::string&, const SnapshotRequest&, const std::function<void(std::int64_t, double)>&,
                        const std::function<bool(const ArrayPiece&)>&) override {
      return Status::ok();
    }
  } none;
  ViewerOptions o;
  o.listen = "0.0.0.0:0";
  auto s = ViewerServer::start(o, none, none);
  ASSERT_FALSE(s);
  EXPECT_NE(s.status().message().find("loopback only"), std::string::npos);
}

}  // namespace
}  // namespace pflow::display
