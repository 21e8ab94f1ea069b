// Services that take calls only from certain peers (label `security`), on loopback over mutual TLS: an agent starts
// work only for the manager; the frontend builds only for the manager; the back-end stores what nodes send and lets
// users read only the jobs the manager says are theirs (asked with the user's own token).
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <sstream>

#include "backend/JobAccess.h"
#include "backend/SnapshotService.h"
#include "frontend/service/FrontendService.h"
#include "manager/ManagerService.h"
#include "manager/Users.h"
#include "manager/agent/AgentService.h"
#include "pflow/agent/v1/agent_service.grpc.pb.h"
#include "pflow/backend/v1/snapshot_service.grpc.pb.h"
#include "pflow/frontend/v1/frontend_service.grpc.pb.h"
#include "tests/agent/AgentTestUtil.h"
#include "tests/manager/TestManager.h"
#include "tests/security/SecurityFixture.h"

namespace pflow::security_test {
namespace {

namespace av1 = pflow::agent::v1;
namespace bv1 = pflow::backend::v1;
namespace fv1 = pflow::frontend::v1;
namespace mv1 = pflow::manager::v1;
using C = grpc::StatusCode;

class AgentPeers : public TlsProcess {
 protected:
  void SetUp() override {
    TlsProcess::SetUp();
    agent::AgentOptions o;
    o.node = "a";
    o.launch.workdir = m_dir.path();
    o.launch.workerPath = agent::testing::writeScript(m_dir / "worker.sh", "echo started > " + (m_dir / "started") + "\nsleep 30");
    o.launch.mpirun = "";
    m_agent = std::make_unique<agent::Agent>(o, std::make_unique<agent::CpuProbe>(1), nullptr);
    m_service = std::make_unique<agent::AgentService>(*m_agent);
    auto server = rpc::ServerRunner::start("127.0.0.1:0", {m_service.get()}, as("node-a"));
    ASSERT_TRUE(server) << server.status().toString();
    m_server = std::move(server.value());
  }
  void TearDown() override {
    if (m_agent) m_agent->shutdown(2);
    if (m_server) m_server->shutdown(1);
    TlsProcess::TearDown();
  }
  grpc::Status start(const rpc::Transport& t) {
    auto stub = av1::AgentService::NewStub(rpc::makeChannel(m_server->address(), t));
    av1::StartJobRequest req;
    av1::Lease* l = req.mutable_lease();
    l->set_job_id("job-000001");
    l->set_model_uri(m_dir.path());
    auto* d = l->add_devices();
    d->set_node("a");
    d->set_kind(pflow::common::v1::DEVICE_KIND_CPU);
    av1::StartJobResponse resp;
    return stub->StartJob(call().get(), req, &resp);
  }
  agent::testing::TempDir m_dir;
  std::unique_ptr<agent::Agent> m_agent;
  std::unique_ptr<agent::AgentService> m_service;
  std::unique_ptr<rpc::ServerRunner> m_server;
};

TEST_F(AgentPeers, LeasesOnlyFromTheManager) {
  EXPECT_EQ(start(user()).error_code(), C::UNAUTHENTICATED);
  EXPECT_EQ(start(as("node-b")).error_code(), C::PERMISSION_DENIED);
  EXPECT_EQ(start(as("backend")).error_code(), C::PERMISSION_DENIED);
  EXPECT_FALSE(std::filesystem::exists(m_dir / "started"));  // nothing ran
  auto stub = av1::AgentService::NewStub(rpc::makeChannel(m_server->address(), as("node-b")));
  av1::StopJobRequest stop;
  stop.set_job_id("job-000001");
  av1::StopJobResponse stopped;
  EXPECT_EQ(stub->StopJob(call().get(), stop, &stopped).error_code(), C::PERMISSION_DENIED);
  EXPECT_TRUE(start(as("manager")).ok());
}

TEST_F(TlsProcess, FrontendBuildsOnlyForTheManager) {
  agent::testing::TempDir dir;
  frontend::ModelStore store(dir.path());
  frontend::FrontendServiceImpl service(store);
  auto server = rpc::ServerRunner::start("127.0.0.1:0", {&service}, as("frontend"));
  ASSERT_TRUE(server);
  for (const auto& [t, code] : {std::pair{user(), C::UNAUTHENTICATED}, {as("node-a"), C::PERMISSION_DENIED}}) {
    auto stub = fv1::FrontendService::NewStub(rpc::makeChannel(server.value()->address(), t));
    fv1::BuildSceneRequest req;
    req.set_scene_yaml("simulation: {duration: 1}");
    fv1::BuildSceneResponse resp;
    EXPECT_EQ(stub->BuildScene(call().get(), req, &resp).error_code(), code);
    fv1::ValidateSceneRequest vreq;
    fv1::ValidateSceneResponse vresp;
    EXPECT_EQ(stub->ValidateScene(call().get(), vreq, &vresp).error_code(), code);
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));  // no model was stored
  server.value()->shutdown(1);
}

// A back-end whose readers are checked with a real manager (ManagerService over TLS, users in SQLite).
class BackendPeers : public TlsProcess {
 protected:
  void SetUp() override {
    TlsProcess::SetUp();
    manager::testing::TestManager::Options o;
    o.transport = as("manager");
    m_tm = std::make_unique<manager::testing::TestManager>(std::move(o));
    m_alice = m_tm->addUser("alice");
    m_bob = m_tm->addUser("bob");
    ASSERT_TRUE(m_tm->manager->heartbeat(manager::testing::nodeBeat("a", 1)));
    m_job = m_tm->submitAs("alice");

    auto store = backend::SnapshotStore::open({m_dir.path(), 0, 8});
    ASSERT_TRUE(store);
    m_store = std::move(store.value());
    rpc::setDefaultTransport(as("backend"));  // the back-end's own calls to the manager
    m_access = backend::makeManagerJobAccess(m_tm->address());
    m_service = std::make_unique<backend::SnapshotService>(*m_store, 2, m_access.get());
    m_server = rpc::ServerRunner::start("127.0.0.1:0", {m_service.get()}, as("backend")).value();
  }
  void TearDown() override {
    if (m_server) m_server->shutdown(1);
    m_tm.reset();
    TlsProcess::TearDown();
  }
  grpc::Status list(const rpc::Transport& t, const std::string& token) {
    auto stub = bv1::SnapshotService::NewStub(rpc::makeChannel(m_server->address(), t));
    bv1::ListSnapshotsRequest req;
    req.set_job_id(m_job);
    bv1::ListSnapshotsResponse resp;
    return stub->ListSnapshots(call(token).get(), req, &resp);
  }
  grpc::Status read(const rpc::Transport& t, const std::string& token) {
    auto stub = bv1::SnapshotService::NewStub(rpc::makeChannel(m_server->address(), t));
    bv1::ReadSnapshotRequest req;
    req.set_job_id(m_job);
    auto ctx = call(token);
    auto reader = stub->ReadSnapshot(ctx.get(), req);
    bv1::SnapshotChunk chunk;
    while (reader->Read(&chunk)) {
    }
    return reader->Finish();
  }

  agent::testing::TempDir m_dir;
  std::unique_ptr<manager::testing::TestManager> m_tm;
  std::string m_alice, m_bob, m_job;
  std::unique_ptr<backend::SnapshotStore> m_store;
  std::unique_ptr<backend::JobAccess> m_access;
  std::unique_ptr<backend::SnapshotService> m_service;
  std::unique_ptr<rpc::ServerRunner> m_server;
};

TEST_F(BackendPeers, UsersReadOnlyTheirOwnJobs) {
  EXPECT_EQ(list(user(), "").error_code(), C::UNAUTHENTICATED);
  EXPECT_EQ(list(user(), "pflow_forged").error_code(), C::UNAUTHENTICATED);
  EXPECT_EQ(list(user(), m_bob).error_code(), C::PERMISSION_DENIED);
  EXPECT_EQ(read(user(), m_bob).error_code(), C::PERMISSION_DENIED);
  // Alice passes the check; the job has no snapshots yet.
  EXPECT_EQ(list(user(), m_alice).error_code(), C::NOT_FOUND);
  EXPECT_EQ(read(user(), m_alice).error_code(), C::NOT_FOUND);
}

TEST_F(BackendPeers, OnlyNodesWrite) {
  for (const auto& [t, code] : {std::pair{user(), C::UNAUTHENTICATED}, {as("frontend"), C::PERMISSION_DENIED}}) {
    auto stub = bv1::SnapshotService::NewStub(rpc::makeChannel(m_server->address(), t));
    bv1::AppendProbesRequest probes;
    probes.set_job_id(m_job);
    bv1::AppendProbesResponse presp;
    EXPECT_EQ(stub->AppendProbes(call(m_alice).get(), probes, &presp).error_code(), code);
    bv1::WriteSnapshotResponse wresp;
    auto wctx = call(m_alice);
    auto writer = stub->WriteSnapshot(wctx.get(), &wresp);
    writer->WritesDone();
    EXPECT_EQ(writer->Finish().error_code(), code);
    bv1::ReadCheckpointRequest creq;
    creq.set_job_id(m_job);
    auto cctx = call(m_alice);
    auto reader = stub->ReadCheckpoint(cctx.get(), creq);
    bv1::CheckpointChunk chunk;
    while (reader->Read(&chunk)) {
    }
    EXPECT_EQ(reader->Finish().error_code(), code);
  }
  for (const auto& e : std::filesystem::recursive_directory_iterator(m_dir.path()))
    EXPECT_EQ(e.path().filename().string().find(m_job), std::string::npos) << "stored: " << e.path();
}

TEST_F(BackendPeers, OneClientCannotFloodTheLog) {
  std::ostringstream captured;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(captured);
  spdlog::default_logger()->sinks().push_back(sink);
  for (int i = 0; i < 300; ++i) EXPECT_EQ(read(user(), m_bob).error_code(), C::PERMISSION_DENIED);  // each one a warning
  spdlog::default_logger()->flush();
  auto& sinks = spdlog::default_logger()->sinks();
  sinks.erase(std::find(sinks.begin(), sinks.end(), sink));
  const std::string log = captured.str();
  const auto lines = std::count(log.begin(), log.end(), '\n');
  EXPECT_GE(lines, 1);
  EXPECT_LE(lines, 25) << log.substr(0, 2000);  // 20 a window per client, not 300
}

}  // namespace
}  // namespace pflow::security_test
