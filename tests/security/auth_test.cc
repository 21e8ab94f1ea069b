// The manager as a hostile caller meets it (label `security`): a real ManagerService and NodeRegistry on loopback
// over mutual TLS with certificates from deploy/local/certs.sh, users with tokens in SQLite, fake agent and frontend
// clients behind. Each test is an attack of issue 19 or its neighbour: no token, a bad token, another user's job, a
// user managing users, a node speaking for another node, a plaintext or foreign-CA client.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include "manager/ManagerService.h"
#include "manager/Users.h"
#include "pflow/manager/v1/manager_service.grpc.pb.h"
#include "pflow/manager/v1/node_registry.grpc.pb.h"
#include "tests/agent/AgentTestUtil.h"
#include "tests/manager/TestManager.h"
#include "tests/security/SecurityFixture.h"

namespace pflow::security_test {
namespace {

namespace mv1 = pflow::manager::v1;
namespace cv1 = pflow::common::v1;
using manager::JobStore;
using manager::Manager;
using manager::ManagerOptions;
using manager::UserStore;
using manager::testing::TestManager;
using C = grpc::StatusCode;

class ManagerSecurity : public TlsProcess {
 protected:
  void SetUp() override {
    TlsProcess::SetUp();
    m_db = m_dir / "manager.db";  // a file: TokensAreStoredOnlyAsHashes reads it
    TestManager::Options o;
    o.db = m_db;
    o.manager.thresholds.particlesPerGpu = 250000;
    o.verifyNodes = true;
    o.transport = as("manager");
    m_tm = std::make_unique<TestManager>(std::move(o));
    m_manager = m_tm->manager.get();
    m_server = m_tm->server.get();
    for (auto [name, admin] : {std::pair{"alice", false}, {"bob", false}, {"root", true}}) m_token[name] = m_tm->addUser(name, admin);
    m_jobs = mv1::ManagerService::NewStub(rpc::makeChannel(m_server->address(), user()));
    ASSERT_TRUE(heartbeat("a", as("node-a")).ok());
  }
  void TearDown() override {
    m_tm.reset();
    TlsProcess::TearDown();
  }

  grpc::Status heartbeat(const std::string& node, const rpc::Transport& as) {
    auto stub = mv1::NodeRegistry::NewStub(rpc::makeChannel(m_server->address(), as));
    mv1::HeartbeatRequest req;
    req.set_node(node);
    req.set_agent_address("127.0.0.1:7000");
    auto* d = req.add_devices();
    d->mutable_ref()->set_node(node);
    d->mutable_ref()->set_kind(cv1::DEVICE_KIND_GPU);
    d->set_name("NVIDIA H100 80GB HBM3");
    d->set_memory_total_bytes(80ull << 30);
    mv1::HeartbeatResponse resp;
    return stub->Heartbeat(call().get(), req, &resp);
  }
  grpc::Status submit(const std::string& who, mv1::Job* job = nullptr) {
    mv1::SubmitJobRequest req;
    req.set_name("demo");
    req.set_scene_yaml(manager::testing::scene(10));
    req.set_scene_name("demo.yaml");
    req.set_wait(true);
    mv1::SubmitJobResponse resp;
    auto s = m_jobs->SubmitJob(call(m_token[who]).get(), req, &resp);
    if (job) *job = resp.job();
    return s;
  }
  grpc::Status getJob(const std::string& token, const std::string& id) {
    mv1::GetJobRequest req;
    req.set_id(id);
    mv1::Job job;
    return m_jobs->GetJob(call(token).get(), req, &job);
  }
  std::vector<std::string> list(const std::string& token) {
    mv1::ListJobsResponse resp;
    EXPECT_TRUE(m_jobs->ListJobs(call(token).get(), mv1::ListJobsRequest(), &resp).ok());
    std::vector<std::string> ids;
    for (const auto& j : resp.jobs()) ids.push_back(j.id());
    return ids;
  }

  agent::testing::TempDir m_dir;
  std::string m_db;
  std::unique_ptr<TestManager> m_tm;
  Manager* m_manager = nullptr;
  rpc::ServerRunner* m_server = nullptr;
  std::map<std::string, std::string> m_token;
  std::unique_ptr<mv1::ManagerService::Stub> m_jobs;
};

TEST_F(ManagerSecurity, NoTokenIsUnauthenticated) {
  mv1::ListJobsResponse resp;
  const auto s = m_jobs->ListJobs(call().get(), mv1::ListJobsRequest(), &resp);
  EXPECT_EQ(s.error_code(), C::UNAUTHENTICATED) << s.error_message();
  mv1::ListNodesResponse nodes;
  EXPECT_EQ(m_jobs->ListNodes(call().get(), mv1::ListNodesRequest(), &nodes).error_code(), C::UNAUTHENTICATED);
  EXPECT_EQ(submit("nobody").error_code(), C::UNAUTHENTICATED);
}

TEST_F(ManagerSecurity, ForgedTokensAreUnauthenticatedAndSayNoMore) {
  const std::string forged = "pflow_" + std::string(64, '0');
  for (const std::string& token : {forged, m_token["alice"] + "x", std::string(4000, 'a'), std::string("tok en;\\\"")}) {
    mv1::ListJobsResponse resp;
    const auto s = m_jobs->ListJobs(call(token).get(), mv1::ListJobsRequest(), &resp);
    EXPECT_EQ(s.error_code(), C::UNAUTHENTICATED);
    EXPECT_EQ(s.error_message(), "the token is not valid");  // nothing about users or near misses
  }
  mv1::ListJobsResponse resp;
  // Bytes a header cannot carry: the client leaves the token out (no crash), the server sees none.
  EXPECT_EQ(m_jobs->ListJobs(call(std::string("\x01\xff")).get(), mv1::ListJobsRequest(), &resp).error_code(), C::UNAUTHENTICATED);
  // A header past gRPC's metadata limit (8 KiB) never reaches the handler.
  EXPECT_EQ(m_jobs->ListJobs(call(std::string(100000, 'a')).get(), mv1::ListJobsRequest(), &resp).error_code(), C::RESOURCE_EXHAUSTED);
}

TEST_F(ManagerSecurity, AnotherUsersJobIsPermissionDenied) {
  mv1::Job job;
  ASSERT_TRUE(submit("alice", &job).ok());
  EXPECT_EQ(job.owner(), "alice");
  EXPECT_TRUE(getJob(m_token["alice"], job.id()).ok());
  const auto s = getJob(m_token["bob"], job.id());
  EXPECT_EQ(s.error_code(), C::PERMISSION_DENIED);
  EXPECT_EQ(s.error_message().find("alice"), std::string::npos) << "names the owner: " << s.error_message();

  mv1::CancelJobRequest cancel;
  cancel.set_id(job.id());
  mv1::Job out;
  EXPECT_EQ(m_jobs->CancelJob(call(m_token["bob"]).get(), cancel, &out).error_code(), C::PERMISSION_DENIED);
  EXPECT_NE(m_manager->get(job.id())->state, manager::JobState::kCancelled);  // untouched

  mv1::WatchJobRequest watch;
  watch.set_id(job.id());
  auto ctx = call(m_token["bob"]);
  auto reader = m_jobs->WatchJob(ctx.get(), watch);
  mv1::JobEvent ev;
  EXPECT_FALSE(reader->Read(&ev));
  EXPECT_EQ(reader->Finish().error_code(), C::PERMISSION_DENIED);
}

TEST_F(ManagerSecurity, ListsHoldOnlyTheCallersJobsExceptForAdmins) {
  mv1::Job a, b;
  ASSERT_TRUE(submit("alice", &a).ok());
  ASSERT_TRUE(submit("bob", &b).ok());
  EXPECT_EQ(list(m_token["alice"]), std::vector<std::string>{a.id()});
  EXPECT_EQ(list(m_token["bob"]), std::vector<std::string>{b.id()});
  EXPECT_EQ(list(m_token["root"]), (std::vector<std::string>{a.id(), b.id()}));
  EXPECT_TRUE(getJob(m_token["root"], a.id()).ok());
}

TEST_F(ManagerSecurity, OnlyAdminsManageUsers) {
  mv1::AddUserRequest add;
  add.set_name("mallory");
  add.set_admin(true);
  mv1::UserTokenResponse resp;
  EXPECT_EQ(m_jobs->AddUser(call(m_token["alice"]).get(), add, &resp).error_code(), C::PERMISSION_DENIED);
  mv1::ListUsersResponse users;
  EXPECT_EQ(m_jobs->ListUsers(call(m_token["alice"]).get(), mv1::ListUsersRequest(), &users).error_code(), C::PERMISSION_DENIED);
  mv1::RotateTokenRequest rotate;
  rotate.set_name("bob");
  EXPECT_EQ(m_jobs->RotateToken(call(m_token["alice"]).get(), rotate, &resp).error_code(), C::PERMISSION_DENIED);
  mv1::RemoveUserRequest remove;
  remove.set_name("bob");
  mv1::RemoveUserResponse removed;
  EXPECT_EQ(m_jobs->RemoveUser(call(m_token["alice"]).get(), remove, &removed).error_code(), C::PERMISSION_DENIED);
  EXPECT_TRUE(getJob(m_token["bob"], "job-000001").error_code() != C::UNAUTHENTICATED);  // bob still there

  add.set_admin(false);
  ASSERT_TRUE(m_jobs->AddUser(call(m_token["root"]).get(), add, &resp).ok());
  EXPECT_EQ(list(resp.token()), std::vector<std::string>{});  // the new token works at once
  EXPECT_EQ(m_jobs->AddUser(call(m_token["root"]).get(), add, &resp).error_code(), C::ALREADY_EXISTS);
  add.set_name("../etc");
  EXPECT_EQ(m_jobs->AddUser(call(m_token["root"]).get(), add, &resp).error_code(), C::INVALID_ARGUMENT);
}

TEST_F(ManagerSecurity, RotatedAndRemovedTokensStopWorking) {
  mv1::RotateTokenRequest rotate;
  rotate.set_name("alice");
  mv1::UserTokenResponse resp;
  ASSERT_TRUE(m_jobs->RotateToken(call(m_token["alice"]).get(), rotate, &resp).ok());  // a user may rotate its own
  mv1::ListJobsResponse jobs;
  EXPECT_EQ(m_jobs->ListJobs(call(m_token["alice"]).get(), mv1::ListJobsRequest(), &jobs).error_code(), C::UNAUTHENTICATED);
  EXPECT_TRUE(m_jobs->ListJobs(call(resp.token()).get(), mv1::ListJobsRequest(), &jobs).ok());

  mv1::RemoveUserRequest remove;
  remove.set_name("bob");
  mv1::RemoveUserResponse removed;
  ASSERT_TRUE(m_jobs->RemoveUser(call(m_token["root"]).get(), remove, &removed).ok());
  EXPECT_EQ(m_jobs->ListJobs(call(m_token["bob"]).get(), mv1::ListJobsRequest(), &jobs).error_code(), C::UNAUTHENTICATED);
}

TEST_F(ManagerSecurity, TokensAreStoredOnlyAsHashes) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(m_db.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT name, token_sha256 FROM users", -1, &st, nullptr), SQLITE_OK);
  int rows = 0;
  while (sqlite3_step(st) == SQLITE_ROW) {
    const std::string name = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    const std::string stored = reinterpret_cast<const char*>(sqlite3_column_text(st, 1));
    EXPECT_NE(stored, m_token[name]);
    EXPECT_EQ(stored.find(m_token[name].substr(6, 16)), std::string::npos);
    EXPECT_EQ(stored, manager::tokenHash(m_token[name]));
    ++rows;
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  EXPECT_EQ(rows, 3);
}

TEST_F(ManagerSecurity, HeartbeatsOnlyForTheCallersOwnNode) {
  EXPECT_EQ(heartbeat("b", as("node-a")).error_code(), C::PERMISSION_DENIED);  // node a forging node b
  EXPECT_EQ(heartbeat("a", user()).error_code(), C::UNAUTHENTICATED);         // no certificate
  EXPECT_EQ(heartbeat("a", as("backend")).error_code(), C::PERMISSION_DENIED); // a service, not a node
  EXPECT_TRUE(heartbeat("b", as("node-b")).ok());
  EXPECT_EQ(m_manager->nodes().size(), 2u);
}

TEST_F(ManagerSecurity, ExitAndProgressReportsOnlyFromTheJobsNode) {
  mv1::Job job;
  ASSERT_TRUE(submit("alice", &job).ok());
  ASSERT_EQ(job.devices_size(), 1);
  ASSERT_EQ(job.devices(0).node(), "a");
  auto report = [&](const rpc::Transport& as, const std::string& node) {
    auto stub = mv1::NodeRegistry::NewStub(rpc::makeChannel(m_server->address(), as));
    mv1::ReportJobExitRequest req;
    req.set_job_id(job.id());
    req.set_node(node);
    req.set_exit_code(0);
    mv1::ReportJobExitResponse resp;
    return stub->ReportJobExit(call().get(), req, &resp);
  };
  ASSERT_TRUE(heartbeat("b", as("node-b")).ok());
  EXPECT_EQ(report(as("node-b"), "a").error_code(), C::PERMISSION_DENIED);  // b speaking for a
  EXPECT_EQ(report(as("node-b"), "b").error_code(), C::FAILED_PRECONDITION);  // b has no part in the job
  EXPECT_EQ(report(as("node-a"), "").error_code(), C::PERMISSION_DENIED);  // an empty node is no one's
  EXPECT_EQ(report(user(), "a").error_code(), C::UNAUTHENTICATED);
  EXPECT_FALSE(manager::isFinal(m_manager->get(job.id())->state));  // none of them ended it

  bool cancel = false;
  auto progress = [&](const rpc::Transport& as) {
    auto stub = mv1::NodeRegistry::NewStub(rpc::makeChannel(m_server->address(), as));
    mv1::ReportProgressRequest req;
    req.set_job_id(job.id());
    req.mutable_progress()->set_step(5);
    mv1::ReportProgressResponse resp;
    const auto s = stub->ReportProgress(call().get(), req, &resp);
    cancel = resp.cancel();
    return s;
  };
  ASSERT_TRUE(progress(as("node-b")).ok());  // a node without the job: not recorded, told to stop its worker
  EXPECT_TRUE(cancel);
  EXPECT_EQ(m_manager->get(job.id())->progress.step, 0);
  EXPECT_TRUE(progress(as("node-a")).ok());
  EXPECT_FALSE(cancel);
  EXPECT_EQ(m_manager->get(job.id())->progress.step, 5);
  EXPECT_TRUE(report(as("node-a"), "a").ok());
  EXPECT_EQ(m_manager->get(job.id())->state, manager::JobState::kSucceeded);
}

TEST_F(ManagerSecurity, PlaintextAndForeignCaClientsCannotConnect) {
  for (const rpc::Transport& t : {rpc::Transport::plaintext(), Certificates::get().stranger()}) {
    auto stub = mv1::ManagerService::NewStub(rpc::makeChannel(m_server->address(), t));
    mv1::ListJobsResponse resp;
    auto ctx = call(m_token["root"]);
    ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(3));
    const auto s = stub->ListJobs(ctx.get(), mv1::ListJobsRequest(), &resp);
    EXPECT_TRUE(s.error_code() == C::UNAVAILABLE || s.error_code() == C::DEADLINE_EXCEEDED) << s.error_code() << " " << s.error_message();
  }
}

TEST(Transport, PlaintextServersListenOnLoopbackOnly) {
  auto server = rpc::ServerRunner::start("0.0.0.0:0", {}, rpc::Transport::plaintext());
  ASSERT_FALSE(server);
  EXPECT_EQ(server.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(server.status().message().find("loopback"), std::string::npos);
}

TEST(Transport, MissingCertificatesAreNamed) {
  rpc::TransportFlags flags;
  auto none = flags.resolve("manager");
  ASSERT_FALSE(none);
  EXPECT_NE(none.status().message().find("--tls-dir"), std::string::npos);
  flags.tlsDir = "/nonexistent";
  auto missing = flags.resolve("manager");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.status().message().find("/nonexistent/ca.crt"), std::string::npos);
}

}  // namespace
}  // namespace pflow::security_test
