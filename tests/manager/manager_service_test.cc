// ManagerService and NodeRegistry through a real channel (127.0.0.1, port 0) with fake agent and frontend clients;
// the gRPC agent and frontend clients against fake AgentService and FrontendService servers.
#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <set>
#include <thread>

#include "common/rpc/Rpc.h"
#include "manager/GrpcAgentClient.h"
#include "manager/GrpcFrontendClient.h"
#include "manager/ManagerService.h"
#include "pflow/agent/v1/agent_service.grpc.pb.h"
#include "pflow/frontend/v1/frontend_service.grpc.pb.h"
#include "tests/manager/Fakes.h"

namespace pflow::manager {
namespace {

namespace mv1 = pflow::manager::v1;
namespace cv1 = pflow::common::v1;
using testing::FakeAgentClient;
using testing::FakeFrontendClient;

class ManagerServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto s = JobStore::open(":memory:");
    ASSERT_TRUE(s);
    store = std::move(s.value());
    ManagerOptions options;
    options.managerAddress = "127.0.0.1:50051";
    options.thresholds.particlesPerGpu = 250000;  // the rule under test, not the measured default
    auto m = Manager::create(options, clock, *store, agents, frontend);
    ASSERT_TRUE(m);
    manager = std::move(m.value());
    pool = std::make_unique<TaskPool>(4);
    auto u = UserStore::open(":memory:");
    ASSERT_TRUE(u);
    users = std::move(u.value());
    auto token = users->add("alice", false, 0);
    ASSERT_TRUE(token);
    rpc::setCallToken(token.value());  // every call of this test is alice's
    managerService = std::make_unique<ManagerServiceImpl>(*manager, *users, *pool);
    registryService = std::make_unique<NodeRegistryImpl>(*manager, *pool, false);
    auto server = rpc::ServerRunner::start("127.0.0.1:0", {managerService.get(), registryService.get()});
    ASSERT_TRUE(server) << server.status().toString();
    runner = std::move(server.value());
    auto channel = rpc::makeChannel(runner->address());
    ASSERT_TRUE(rpc::waitForConnected(channel, 10));
    jobs = mv1::ManagerService::NewStub(channel);
    registry = mv1::NodeRegistry::NewStub(channel);
  }
  void TearDown() override {
    runner->shutdown(1);
    pool.reset();
    rpc::setCallToken("");
  }

  grpc::Status heartbeat(const std::string& node, int gpus, std::vector<std::string> running = {}, mv1::HeartbeatResponse* out = nullptr) {
    mv1::HeartbeatRequest req;
    req.set_node(node);
    req.set_agent_address(node + ":7000");
    for (int i = 0; i < gpus; ++i) {
      auto* d = req.add_devices();
      d->mutable_ref()->set_node(node);
      d->mutable_ref()->set_index(i);
      d->mutable_ref()->set_kind(cv1::DEVICE_KIND_GPU);
      d->set_name("NVIDIA H100 80GB HBM3");
      d->set_memory_total_bytes(80ull << 30);
    }
    for (auto& id : running) req.add_running_jobs(id);
    mv1::HeartbeatResponse resp;
    auto ctx = rpc::contextWithDeadline(10);
    auto s = registry->Heartbeat(ctx.get(), req, &resp);
    if (out) *out = resp;
    return s;
  }
  grpc::Status submit(std::uint64_t particles, bool wait, mv1::Job* job) {
    mv1::SubmitJobRequest req;
    req.set_name("demo");
    req.set_scene_yaml(testing::scene(particles));
    req.set_scene_name("demo.yaml");
    req.set_wait(wait);
    mv1::SubmitJobResponse resp;
    auto ctx = rpc::contextWithDeadline(10);
    auto s = jobs->SubmitJob(ctx.get(), req, &resp);
    if (job) *job = resp.job();
    return s;
  }
  grpc::Status progress(const std::string& id, std::int64_t step, bool* cancel) {
    mv1::ReportProgressRequest req;
    req.set_job_id(id);
    req.mutable_progress()->set_step(step);
    req.mutable_progress()->set_total_steps(1000);
    req.mutable_progress()->set_particle_steps_per_second(1e6);
    req.set_message("step " + std::to_string(step));
    mv1::ReportProgressResponse resp;
    auto ctx = rpc::contextWithDeadline(10);
    auto s = registry->ReportProgress(ctx.get(), req, &resp);
    if (cancel) *cancel = resp.cancel();
    return s;
  }
  grpc::Status exitJob(const std::string& id, int code, const std::string& node = "a") {
    mv1::ReportJobExitRequest req;
    req.set_job_id(id);
    req.set_node(node);
    req.set_exit_code(code);
    mv1::ReportJobExitResponse resp;
    auto ctx = rpc::contextWithDeadline(10);
    return registry->ReportJobExit(ctx.get(), req, &resp);
  }
  mv1::Job getJob(const std::string& id, grpc::Status* status = nullptr) {
    mv1::GetJobRequest req;
    req.set_id(id);
    mv1::Job job;
    auto ctx = rpc::contextWithDeadline(10);
    auto s = jobs->GetJob(ctx.get(), req, &job);
    if (status) *status = s;
    return job;
  }
  grpc::Status cancel(const std::string& id, mv1::Job* job = nullptr) {
    mv1::CancelJobRequest req;
    req.set_id(id);
    mv1::Job resp;
    auto ctx = rpc::contextWithDeadline(10);
    auto s = jobs->CancelJob(ctx.get(), req, &resp);
    if (job) *job = resp;
    return s;
  }

  // Reads a WatchJob stream on a thread until it ends.
  struct Watch {
    std::unique_ptr<grpc::ClientContext> ctx;
    std::unique_ptr<grpc::ClientReader<mv1::JobEvent>> reader;
    std::vector<mv1::JobEvent> events;
    std::mutex mu;
    std::condition_variable cv;
    grpc::Status status;
    bool done = false;
    std::thread thread;
    std::size_t count() {
      std::lock_guard lock(mu);
      return events.size();
    }
    bool waitFor(std::size_t n) {
      std::unique_lock lock(mu);
      return cv.wait_for(lock, std::chrono::seconds(10), [&] { return events.size() >= n || done; }) && events.size() >= n;
    }
    bool waitDone() {
      std::unique_lock lock(mu);
      return cv.wait_for(lock, std::chrono::seconds(10), [&] { return done; });
    }
  };
  std::unique_ptr<Watch> watch(const std::string& id) {
    auto w = std::make_unique<Watch>();
    w->ctx = rpc::contextWithDeadline(30);
    mv1::WatchJobRequest req;
    req.set_id(id);
    w->reader = jobs->WatchJob(w->ctx.get(), req);
    Watch* raw = w.get();
    w->thread = std::thread([raw] {
      mv1::JobEvent ev;
      while (raw->reader->Read(&ev)) {
        std::lock_guard lock(raw->mu);
        raw->events.push_back(ev);
        raw->cv.notify_all();
      }
      grpc::Status s = raw->reader->Finish();
      std::lock_guard lock(raw->mu);
      raw->status = s;
      raw->done = true;
      raw->cv.notify_all();
    });
    return w;
  }

  FakeClock clock;
  FakeAgentClient agents;
  FakeFrontendClient frontend;
  std::unique_ptr<JobStore> store;
  std::unique_ptr<Manager> manager;
  std::unique_ptr<TaskPool> pool;
  std::unique_ptr<UserStore> users;
  std::unique_ptr<ManagerServiceImpl> managerService;
  std::unique_ptr<NodeRegistryImpl> registryService;
  std::unique_ptr<rpc::ServerRunner> runner;
  std::unique_ptr<mv1::ManagerService::Stub> jobs;
  std::unique_ptr<mv1::NodeRegistry::Stub> registry;
};

TEST_F(ManagerServiceTest, SubmitHeartbeatProgressExitSucceedsAndWatchStreamsToTheEnd) {
  mv1::HeartbeatResponse hb;
  ASSERT_TRUE(heartbeat("a", 2, {}, &hb).ok());
  EXPECT_EQ(hb.heartbeat_interval_seconds(), 2);

  mv1::Job job;
  auto s = submit(600000, false, &job);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(job.state(), mv1::JOB_STATE_RUNNING);
  EXPECT_EQ(job.particles(), 600000u);
  EXPECT_EQ(job.devices_size(), 2);
  EXPECT_EQ(job.devices(0).kind(), cv1::DEVICE_KIND_GPU);
  ASSERT_EQ(agents.startsCopy().size(), 1u);
  EXPECT_EQ(agents.startsCopy()[0].lease.managerAddress, "127.0.0.1:50051");

  auto w = watch(job.id());
  ASSERT_TRUE(w->waitFor(1));
  bool cancelRequested = true;
  ASSERT_TRUE(progress(job.id(), 100, &cancelRequested).ok());
  EXPECT_FALSE(cancelRequested);
  ASSERT_TRUE(w->waitFor(2));
  ASSERT_TRUE(heartbeat("a", 2, {job.id()}).ok());

  {
    mv1::ListNodesRequest req;
    mv1::ListNodesResponse resp;
    auto ctx = rpc::contextWithDeadline(10);
    ASSERT_TRUE(jobs->ListNodes(ctx.get(), req, &resp).ok());
    ASSERT_EQ(resp.nodes_size(), 1);
    EXPECT_EQ(resp.nodes(0).name(), "a");
    EXPECT_FALSE(resp.nodes(0).lost());
    ASSERT_EQ(resp.nodes(0).devices_size(), 2);
    EXPECT_EQ(resp.nodes(0).devices(0).state(), mv1::DEVICE_STATE_BUSY);
    EXPECT_EQ(resp.nodes(0).devices(0).job_id(), job.id());
  }

  ASSERT_TRUE(exitJob(job.id(), 0).ok());
  ASSERT_TRUE(w->waitDone());
  w->thread.join();
  EXPECT_TRUE(w->status.ok()) << w->status.error_message();
  ASSERT_GE(w->events.size(), 3u);
  EXPECT_EQ(w->events.front().job().state(), mv1::JOB_STATE_RUNNING);
  bool sawProgress = false;
  for (const auto& ev : w->events)
    if (!sawProgress && ev.job().progress().step() == 100) {
      sawProgress = true;
      EXPECT_EQ(ev.message(), "step 100");
      EXPECT_DOUBLE_EQ(ev.job().progress().eta_seconds(), 900.0 * 600000 / 1e6);
    }
  EXPECT_TRUE(sawProgress);
  EXPECT_EQ(w->events.back().job().state(), mv1::JOB_STATE_SUCCEEDED);

  EXPECT_EQ(getJob(job.id()).state(), mv1::JOB_STATE_SUCCEEDED);
  mv1::ListJobsRequest lreq;
  mv1::ListJobsResponse lresp;
  auto ctx = rpc::contextWithDeadline(10);
  ASSERT_TRUE(jobs->ListJobs(ctx.get(), lreq, &lresp).ok());
  EXPECT_EQ(lresp.jobs_size(), 1);
  lreq.set_active_only(true);
  auto ctx2 = rpc::contextWithDeadline(10);
  ASSERT_TRUE(jobs->ListJobs(ctx2.get(), lreq, &lresp).ok());
  EXPECT_EQ(lresp.jobs_size(), 0);
}

TEST_F(ManagerServiceTest, CancelThroughTheServiceEndsTheWatch) {
  ASSERT_TRUE(heartbeat("a", 1).ok());
  mv1::Job job;
  ASSERT_TRUE(submit(10, false, &job).ok());
  auto w = watch(job.id());
  ASSERT_TRUE(w->waitFor(1));
  mv1::Job cancelled;
  ASSERT_TRUE(cancel(job.id(), &cancelled).ok());
  EXPECT_EQ(cancelled.state(), mv1::JOB_STATE_CANCELLING);
  ASSERT_TRUE(cancel(job.id()).ok());  // twice: idempotent
  bool cancelRequested = false;
  ASSERT_TRUE(progress(job.id(), 5, &cancelRequested).ok());
  EXPECT_TRUE(cancelRequested);
  ASSERT_TRUE(exitJob(job.id(), 143).ok());
  ASSERT_TRUE(w->waitDone());
  w->thread.join();
  EXPECT_TRUE(w->status.ok());
  EXPECT_EQ(w->events.back().job().state(), mv1::JOB_STATE_CANCELLED);
  EXPECT_EQ(w->events.back().job().reason(), "cancelled by request");
}

TEST_F(ManagerServiceTest, QueuedJobStartsAfterTheFirstExits) {
  ASSERT_TRUE(heartbeat("a", 1).ok());
  mv1::Job first, second;
  ASSERT_TRUE(submit(10, false, &first).ok());
  ASSERT_TRUE(submit(10, true, &second).ok());
  EXPECT_EQ(second.state(), mv1::JOB_STATE_QUEUED);
  auto w = watch(second.id());
  ASSERT_TRUE(w->waitFor(1));
  ASSERT_TRUE(exitJob(first.id(), 0).ok());
  ASSERT_TRUE(w->waitFor(2));
  EXPECT_EQ(getJob(second.id()).state(), mv1::JOB_STATE_RUNNING);
  ASSERT_TRUE(exitJob(second.id(), 1).ok());
  ASSERT_TRUE(w->waitDone());
  w->thread.join();
  EXPECT_EQ(w->events.back().job().state(), mv1::JOB_STATE_FAILED);
}

TEST_F(ManagerServiceTest, ClientCancelsItsWatch) {
  ASSERT_TRUE(heartbeat("a", 1).ok());
  mv1::Job job;
  ASSERT_TRUE(submit(10, false, &job).ok());
  auto w = watch(job.id());
  ASSERT_TRUE(w->waitFor(1));
  w->ctx->TryCancel();
  ASSERT_TRUE(w->waitDone());
  w->thread.join();
  EXPECT_EQ(w->status.error_code(), grpc::StatusCode::CANCELLED);
  // The manager carries on (the watcher is gone, nothing dangles).
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(progress(job.id(), i, nullptr).ok());
  ASSERT_TRUE(exitJob(job.id(), 0).ok());
  EXPECT_EQ(getJob(job.id()).state(), mv1::JOB_STATE_SUCCEEDED);
}

TEST_F(ManagerServiceTest, HeartbeatDevicesMayLeaveTheirNodeImplicit) {
  mv1::HeartbeatRequest req;
  req.set_node("n1");
  req.set_agent_address("n1:7000");
  auto* d = req.add_devices();
  d->mutable_ref()->set_index(0);
  d->mutable_ref()->set_kind(cv1::DEVICE_KIND_CPU);
  d->set_name("CPU slot (16 cores)");
  mv1::HeartbeatResponse resp;
  auto ctx = rpc::contextWithDeadline(10);
  ASSERT_TRUE(registry->Heartbeat(ctx.get(), req, &resp).ok());
  const auto nodes = manager->nodes();
  ASSERT_EQ(nodes.size(), 1u);
  ASSERT_EQ(nodes[0].devices.size(), 1u);
  EXPECT_EQ(nodes[0].devices[0].info.key.node, "n1");
  EXPECT_EQ(nodes[0].devices[0].info.key.kind, DeviceKind::kCpu);
  d->mutable_ref()->set_node("other");
  auto ctx2 = rpc::contextWithDeadline(10);
  const auto s = registry->Heartbeat(ctx2.get(), req, &resp);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("not the heartbeat's node"), std::string::npos) << s.error_message();
}

TEST_F(ManagerServiceTest, BadRequestsGetTheDocumentedCodes) {
  using C = grpc::StatusCode;
  // No devices at all.
  auto s = submit(10, true, nullptr);
  EXPECT_EQ(s.error_code(), C::FAILED_PRECONDITION);
  EXPECT_NE(s.error_message().find("no devices"), std::string::npos);

  // Heartbeats: empty node, a device without a kind.
  mv1::HeartbeatRequest bad;
  mv1::HeartbeatResponse hbResp;
  auto ctx = rpc::contextWithDeadline(10);
  s = registry->Heartbeat(ctx.get(), bad, &hbResp);
  EXPECT_EQ(s.error_code(), C::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("node"), std::string::npos);
  bad.set_node("a");
  bad.set_agent_address("a:1");
  bad.add_devices()->mutable_ref()->set_node("a");
  auto ctx2 = rpc::contextWithDeadline(10);
  s = registry->Heartbeat(ctx2.get(), bad, &hbResp);
  EXPECT_EQ(s.error_code(), C::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("devices[0].ref.kind"), std::string::npos) << s.error_message();

  ASSERT_TRUE(heartbeat("a", 1).ok());
  // Empty scene; invalid scene.
  mv1::SubmitJobRequest req;
  mv1::SubmitJobResponse resp;
  auto ctx3 = rpc::contextWithDeadline(10);
  s = jobs->SubmitJob(ctx3.get(), req, &resp);
  EXPECT_EQ(s.error_code(), C::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("scene_yaml"), std::string::npos);
  req.set_scene_yaml("invalid");
  auto ctx4 = rpc::contextWithDeadline(10);
  s = jobs->SubmitJob(ctx4.get(), req, &resp);
  EXPECT_EQ(s.error_code(), C::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("density"), std::string::npos);

  // Busy and not waiting.
  mv1::Job job;
  ASSERT_TRUE(submit(10, false, &job).ok());
  EXPECT_EQ(submit(10, false, nullptr).error_code(), C::RESOURCE_EXHAUSTED);

  // Unknown and empty ids.
  grpc::Status gs;
  getJob("job-404", &gs);
  EXPECT_EQ(gs.error_code(), C::NOT_FOUND);
  EXPECT_NE(gs.error_message().find("job-404"), std::string::npos);
  getJob("", &gs);
  EXPECT_EQ(gs.error_code(), C::INVALID_ARGUMENT);
  EXPECT_EQ(cancel("job-404").error_code(), C::NOT_FOUND);
  EXPECT_EQ(progress("job-404", 1, nullptr).error_code(), C::NOT_FOUND);
  EXPECT_EQ(progress("", 1, nullptr).error_code(), C::INVALID_ARGUMENT);
  EXPECT_EQ(exitJob("", 0).error_code(), C::INVALID_ARGUMENT);
  EXPECT_EQ(exitJob(job.id(), 0, "elsewhere").error_code(), C::FAILED_PRECONDITION);
  auto w = watch("job-404");
  ASSERT_TRUE(w->waitDone());
  w->thread.join();
  EXPECT_EQ(w->status.error_code(), C::NOT_FOUND);
  EXPECT_TRUE(w->events.empty());

  // A finished job cannot be cancelled.
  ASSERT_TRUE(exitJob(job.id(), 0).ok());
  s = cancel(job.id());
  EXPECT_EQ(s.error_code(), C::FAILED_PRECONDITION);
  EXPECT_NE(s.error_message().find("already SUCCEEDED"), std::string::npos);
  EXPECT_EQ(getJob(job.id()).state(), mv1::JOB_STATE_SUCCEEDED);
}

TEST_F(ManagerServiceTest, ConcurrentClientsDrainTheQueue) {
  for (const char* node : {"a", "b", "c", "d"}) ASSERT_TRUE(heartbeat(node, 2).ok());
  constexpr int kThreads = 4, kJobsPerThread = 8;
  std::atomic<int> succeeded{0}, watchesOk{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int k = 0; k < kJobsPerThread; ++k) {
        mv1::Job job;
        if (!submit(10 + t, /*wait=*/true, &job).ok()) return;
        auto w = watch(job.id());
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (getJob(job.id()).state() != mv1::JOB_STATE_RUNNING && std::chrono::steady_clock::now() < deadline)
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        for (int step = 1; step <= 3; ++step) progress(job.id(), step * 100, nullptr);
        const std::string node = getJob(job.id()).devices(0).node();
        if (k % 3 == 2) {  // some are cancelled instead
          cancel(job.id());
          exitJob(job.id(), 143, node);
        } else {
          exitJob(job.id(), 0, node);
        }
        if (w->waitDone() && w->status.ok()) ++watchesOk;
        w->thread.join();
        const auto state = getJob(job.id()).state();
        if (state == mv1::JOB_STATE_SUCCEEDED || state == mv1::JOB_STATE_CANCELLED) ++succeeded;
      }
    });
  }
  // Agents keep heartbeating meanwhile.
  std::atomic<bool> stop{false};
  std::thread beats([&] {
    while (!stop) {
      for (const char* node : {"a", "b", "c", "d"}) heartbeat(node, 2);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  for (auto& th : threads) th.join();
  stop = true;
  beats.join();
  EXPECT_EQ(succeeded.load(), kThreads * kJobsPerThread);
  EXPECT_EQ(watchesOk.load(), kThreads * kJobsPerThread);
  for (const NodeView& n : manager->nodes())
    for (const DeviceView& d : n.devices) EXPECT_EQ(d.state, DeviceState::kFree) << d.info.key.toString() << " " << d.jobId;
  EXPECT_TRUE(manager->list(true).empty());
}

// ---- the gRPC clients against fake servers --------------------------------------------------------------------------

class FakeAgentService final : public pflow::agent::v1::AgentService::Service {
 public:
  grpc::Status StartJob(grpc::ServerContext*, const pflow::agent::v1::StartJobRequest* req, pflow::agent::v1::StartJobResponse* resp) override {
    std::lock_guard lock(mu);
    if (running.count(req->lease().job_id())) return {grpc::StatusCode::ALREADY_EXISTS, "already runs"};
    running.insert(req->lease().job_id());
    lastLease = req->lease();
    resp->set_pid(4242);
    return grpc::Status::OK;
  }
  grpc::Status StopJob(grpc::ServerContext*, const pflow::agent::v1::StopJobRequest* req, pflow::agent::v1::StopJobResponse*) override {
    std::lock_guard lock(mu);
    if (!running.erase(req->job_id())) return {grpc::StatusCode::NOT_FOUND, "job " + req->job_id() + " does not run here"};
    return grpc::Status::OK;
  }
  std::mutex mu;
  std::set<std::string> running;
  pflow::agent::v1::Lease lastLease;
};

TEST(GrpcAgentClient, StartsAndStopsThroughARealChannel) {
  FakeAgentService service;
  auto server = rpc::ServerRunner::start("127.0.0.1:0", {&service});
  ASSERT_TRUE(server);
  GrpcAgentClient client(5);
  Lease lease;
  lease.jobId = "job-000001";
  lease.modelUri = "/models/x";
  lease.devices = {{"a", 0, DeviceKind::kGpu}, {"b", 1, DeviceKind::kGpu}};
  lease.nodeHosts = {{"a", "host-a"}, {"b", "host-b"}};
  lease.managerAddress = "mgr:1";
  lease.backendAddress = "be:2";
  auto pid = client.startJob(server.value()->address(), lease);
  ASSERT_TRUE(pid) << pid.status().toString();
  EXPECT_EQ(pid.value(), 4242);
  {
    std::lock_guard lock(service.mu);
    EXPECT_EQ(service.lastLease.devices_size(), 2);
    EXPECT_EQ(service.lastLease.devices(1).node(), "b");
    EXPECT_EQ(service.lastLease.devices(1).index(), 1);
    EXPECT_EQ(service.lastLease.node_hosts().at("b"), "host-b");
    EXPECT_EQ(service.lastLease.manager_address(), "mgr:1");
    EXPECT_EQ(service.lastLease.backend_address(), "be:2");
  }
  EXPECT_EQ(client.startJob(server.value()->address(), lease).status().code(), StatusCode::kAlreadyExists);
  EXPECT_TRUE(client.stopJob(server.value()->address(), "job-000001"));
  EXPECT_EQ(client.stopJob(server.value()->address(), "job-000001").code(), StatusCode::kNotFound);
}

TEST(GrpcAgentClient, UnreachableAgentIsUnavailableWithinTheDeadline) {
  GrpcAgentClient client(1.0);
  const auto t0 = std::chrono::steady_clock::now();
  const Status s = client.stopJob("127.0.0.1:1", "job-1");
  EXPECT_FALSE(s);
  EXPECT_TRUE(s.code() == StatusCode::kUnavailable || s.code() == StatusCode::kDeadlineExceeded) << s.toString();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
}

class FakeFrontendService final : public pflow::frontend::v1::FrontendService::Service {
 public:
  grpc::Status BuildScene(grpc::ServerContext*, const pflow::frontend::v1::BuildSceneRequest* req,
                          pflow::frontend::v1::BuildSceneResponse* resp) override {
    if (req->scene_yaml().find("bad") != std::string::npos)
      return {grpc::StatusCode::FAILED_PRECONDITION, "1 error(s)\nparticles[0].count: must be positive"};
    resp->set_model_id("abc");
    resp->set_model_uri("/models/abc");
    resp->mutable_summary()->set_particles(123456);
    resp->mutable_summary()->set_memory_bytes(1.5e9);
    resp->mutable_summary()->set_steps(5000);
    resp->mutable_summary()->set_duration(2.5);
    files = req->files_size();
    return grpc::Status::OK;
  }
  std::atomic<int> files{0};
};

TEST(GrpcFrontendClient, BuildsAndReportsInvalidScenes) {
  FakeFrontendService service;
  auto server = rpc::ServerRunner::start("127.0.0.1:0", {&service});
  ASSERT_TRUE(server);
  GrpcFrontendClient client(server.value()->address(), 5);
  auto m = client.buildScene("scene", "s.yaml", {{"mesh.stl", "solid"}});
  ASSERT_TRUE(m) << m.status().toString();
  EXPECT_EQ(m->modelId, "abc");
  EXPECT_EQ(m->modelUri, "/models/abc");
  EXPECT_EQ(m->particles, 123456u);
  EXPECT_EQ(m->memoryBytes, 1.5e9);
  EXPECT_EQ(m->steps, 5000);
  EXPECT_EQ(service.files.load(), 1);
  auto bad = client.buildScene("bad", "s.yaml", {});
  EXPECT_EQ(bad.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("particles[0].count"), std::string::npos);
  GrpcFrontendClient none("");
  EXPECT_EQ(none.buildScene("x", "y", {}).status().code(), StatusCode::kUnavailable);
}

}  // namespace
}  // namespace pflow::manager
