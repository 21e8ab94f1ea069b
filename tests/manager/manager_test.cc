// The Manager domain class with fake agents and frontend and a FakeClock (gcs_node_manager_test style): submit,
// queueing, cancel in every state, lost nodes, restart from SQLite, progress and watch events.
#include "manager/Manager.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "tests/manager/Fakes.h"

namespace pflow::manager {
namespace {

using testing::FakeAgentClient;
using testing::FakeFrontendClient;
using testing::nodeBeat;
using testing::submitRequest;

class ManagerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    options.managerAddress = "mgr:50051";
    options.backendAddress = "backend:50053";
    options.thresholds.particlesPerGpu = 250000;  // the rule under test, not the measured default
    auto s = JobStore::open(":memory:");
    ASSERT_TRUE(s);
    store = std::move(s.value());
    makeManager();
  }
  void makeManager() {
    auto m = Manager::create(options, clock, *store, agents, frontend);
    ASSERT_TRUE(m) << m.status().toString();
    manager = std::move(m.value());
  }
  Job job(const std::string& id) {
    auto j = manager->get(id);
    EXPECT_TRUE(j) << j.status().toString();
    return j ? j.value() : Job{};
  }
  DeviceState deviceState(const std::string& node, int index, std::string* jobId = nullptr) {
    for (const NodeView& n : manager->nodes())
      for (const DeviceView& d : n.devices)
        if (n.name == node && d.info.key.index == index) {
          if (jobId) *jobId = d.jobId;
          return d.state;
        }
    ADD_FAILURE() << "no device " << node << "/" << index;
    return DeviceState::kLost;
  }

  ManagerOptions options;
  FakeClock clock;
  FakeAgentClient agents;
  FakeFrontendClient frontend;
  std::unique_ptr<JobStore> store;
  std::unique_ptr<Manager> manager;
};

TEST_F(ManagerTest, SubmitPlacesStartsAndRunsToSuccess) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 4)));
  auto j = manager->submit(submitRequest(600000));  // 2 GPUs
  ASSERT_TRUE(j) << j.status().toString();
  EXPECT_EQ(j->state, JobState::kRunning);
  EXPECT_EQ(j->id, "job-000001");
  EXPECT_EQ(j->modelUri, "/models/model-1");
  EXPECT_EQ(j->particles, 600000u);
  ASSERT_EQ(j->devices.size(), 2u);

  const auto starts = agents.startsCopy();
  ASSERT_EQ(starts.size(), 1u);
  EXPECT_EQ(starts[0].address, "a:7000");
  const Lease& lease = starts[0].lease;
  EXPECT_EQ(lease.jobId, j->id);
  EXPECT_EQ(lease.modelUri, "/models/model-1");
  EXPECT_EQ(lease.devices, j->devices);
  EXPECT_EQ(lease.nodeHosts.at("a"), "a");
  EXPECT_EQ(lease.managerAddress, "mgr:50051");
  EXPECT_EQ(lease.backendAddress, "backend:50053");

  std::string holder;
  EXPECT_EQ(deviceState("a", 0, &holder), DeviceState::kBusy);
  EXPECT_EQ(holder, j->id);
  EXPECT_EQ(deviceState("a", 2), DeviceState::kFree);

  auto cancel = manager->reportProgress(j->id, {10, 1000, 0.01, 1.0, 1e6, 0}, "executor: CUDA");
  ASSERT_TRUE(cancel);
  EXPECT_FALSE(cancel.value());
  ASSERT_TRUE(manager->reportExit(j->id, "a", 0, ""));
  const Job done = job(j->id);
  EXPECT_EQ(done.state, JobState::kSucceeded);
  EXPECT_GT(done.finishedAt, 0);
  EXPECT_EQ(done.devices.size(), 2u);  // kept for the record
  EXPECT_EQ(deviceState("a", 0), DeviceState::kFree);
  EXPECT_EQ(manager->list(true).size(), 0u);
  EXPECT_EQ(manager->list(false).size(), 1u);
}

TEST_F(ManagerTest, SubmitValidatesTheRequest) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  SubmitRequest r = submitRequest(10);
  r.sceneYaml.clear();
  r.maxDevices = -1;
  r.files = {{"mesh.stl", "x"}, {"mesh.stl", "y"}};
  auto j = manager->submit(r);
  ASSERT_FALSE(j);
  EXPECT_EQ(j.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(j.status().message().find("scene_yaml"), std::string::npos);
  EXPECT_NE(j.status().message().find("max_devices"), std::string::npos);
  EXPECT_NE(j.status().message().find("repeats 'mesh.stl'"), std::string::npos);

  r = submitRequest(10);
  r.sceneYaml = "invalid scene";
  j = manager->submit(r);
  EXPECT_EQ(j.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(j.status().message().find("materials[0].density"), std::string::npos);

  j = manager->submit(submitRequest(0));
  EXPECT_EQ(j.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(j.status().message().find("no particles"), std::string::npos);

  frontend.unavailableError = unavailable("frontend at f:1 unavailable");
  j = manager->submit(submitRequest(10));
  EXPECT_EQ(j.status().code(), StatusCode::kUnavailable);
  EXPECT_TRUE(manager->list(false).empty());  // nothing stored
}

TEST_F(ManagerTest, RefusesWhenBusyUnlessAskedToWait) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 2)));
  auto first = manager->submit(submitRequest(500000));  // both GPUs
  ASSERT_TRUE(first);
  auto refused = manager->submit(submitRequest(10, /*wait=*/false));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("0 of 2 are free"), std::string::npos) << refused.status().message();
  EXPECT_EQ(manager->list(false).size(), 1u);  // the refused job is not stored
}

TEST_F(ManagerTest, NeverFitsIsRefusedAtSubmit) {
  auto none = manager->submit(submitRequest(10, true));
  EXPECT_EQ(none.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(none.status().message().find("no devices"), std::string::npos);
  EXPECT_EQ(frontend.builds, 0);  // refused before building

  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 2, 0, 10'000'000'000ull)));
  SubmitRequest r = submitRequest(10, true);
  r.sceneYaml += "memory: 50e9\n";
  auto big = manager->submit(r);
  ASSERT_FALSE(big);
  EXPECT_EQ(big.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(big.status().message().find("needs at least 6 GPUs but only 2 exist"), std::string::npos) << big.status().message();
}

TEST_F(ManagerTest, QueuedJobStartsWhenDevicesFreeUpInFifoOrder) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 2)));
  auto j1 = manager->submit(submitRequest(500000));              // 2 GPUs
  auto j2 = manager->submit(submitRequest(500000, /*wait=*/true));  // 2 GPUs: waits
  auto j3 = manager->submit(submitRequest(10, /*wait=*/true));      // 1 GPU: waits behind j2 (FIFO)
  ASSERT_TRUE(j1 && j2 && j3);
  EXPECT_EQ(j1->state, JobState::kRunning);
  EXPECT_EQ(j2->state, JobState::kQueued);
  EXPECT_NE(j2->reason.find("needs 2 GPUs; 0 of 2 are free"), std::string::npos) << j2->reason;
  EXPECT_EQ(j3->state, JobState::kQueued);
  // A non-waiting job may not jump the queue either.
  auto j4 = manager->submit(submitRequest(10, false));
  EXPECT_EQ(j4.status().code(), StatusCode::kResourceExhausted);

  ASSERT_TRUE(manager->reportExit(j1->id, "a", 0, ""));
  EXPECT_EQ(job(j1->id).state, JobState::kSucceeded);
  EXPECT_EQ(job(j2->id).state, JobState::kRunning);
  EXPECT_TRUE(job(j2->id).reason.empty());
  EXPECT_EQ(job(j3->id).state, JobState::kQueued);

  ASSERT_TRUE(manager->reportExit(j2->id, "a", 3, "non-finite velocity of particle 17"));
  const Job failed = job(j2->id);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_EQ(failed.exitCode, 3);
  EXPECT_NE(failed.reason.find("exit code 3: non-finite velocity"), std::string::npos) << failed.reason;
  EXPECT_EQ(job(j3->id).state, JobState::kRunning);
  EXPECT_EQ(agents.startsCopy().size(), 3u);
}

TEST_F(ManagerTest, NewNodeStartsQueuedJobs) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j1 = manager->submit(submitRequest(10));
  auto j2 = manager->submit(submitRequest(10, true));
  ASSERT_TRUE(j1 && j2);
  EXPECT_EQ(j2->state, JobState::kQueued);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1)));
  EXPECT_EQ(job(j2->id).state, JobState::kRunning);
  EXPECT_EQ(job(j2->id).devices.front().node, "b");
}

TEST_F(ManagerTest, StartFailureFailsTheJobAndFreesItsDevices) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  agents.startError = unavailable("agent at a:7000 unreachable");
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  EXPECT_EQ(j->state, JobState::kFailed);
  EXPECT_NE(j->reason.find("the agent on node a could not start the job: agent at a:7000 unreachable"), std::string::npos) << j->reason;
  EXPECT_EQ(deviceState("a", 0), DeviceState::kFree);
}

TEST_F(ManagerTest, AlreadyRunningCountsAsStarted) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  agents.startError = alreadyExists("job runs here");
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  EXPECT_EQ(j->state, JobState::kRunning);
}

TEST_F(ManagerTest, CancelQueued) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j1 = manager->submit(submitRequest(10));
  auto j2 = manager->submit(submitRequest(10, true));
  ASSERT_TRUE(j1 && j2);
  auto c = manager->cancel(j2->id);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->state, JobState::kCancelled);
  EXPECT_EQ(c->reason, "cancelled while queued");
  EXPECT_TRUE(agents.stopsCopy().empty());
  // Cancelling a cancelled job again is idempotent.
  auto again = manager->cancel(j2->id);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->state, JobState::kCancelled);
  EXPECT_EQ(again->finishedAt, c->finishedAt);
}

TEST_F(ManagerTest, CancelRunningGoesThroughCancelling) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  auto c = manager->cancel(j->id);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->state, JobState::kCancelling);
  ASSERT_EQ(agents.stopsCopy().size(), 1u);
  EXPECT_EQ(agents.stopsCopy()[0].address, "a:7000");
  EXPECT_EQ(agents.stopsCopy()[0].jobId, j->id);
  EXPECT_EQ(deviceState("a", 0), DeviceState::kBusy);  // until the worker exits

  auto cancel = manager->reportProgress(j->id, {5, 1000, 0.005, 1, 0, 0}, "");
  ASSERT_TRUE(cancel);
  EXPECT_TRUE(cancel.value());
  // The agent's heartbeat still lists it: the answer asks it to stop.
  auto hb = manager->heartbeat(nodeBeat("a", 1, 0, 80ull << 30, {j->id}));
  ASSERT_TRUE(hb);
  EXPECT_EQ(hb->stopJobs, std::vector<std::string>{j->id});

  auto twice = manager->cancel(j->id);  // idempotent
  ASSERT_TRUE(twice);
  EXPECT_EQ(twice->state, JobState::kCancelling);

  ASSERT_TRUE(manager->reportExit(j->id, "a", 143, "SIGTERM"));
  const Job done = job(j->id);
  EXPECT_EQ(done.state, JobState::kCancelled);
  EXPECT_EQ(done.reason, "cancelled by request");
  EXPECT_EQ(done.exitCode, 143);
  EXPECT_EQ(deviceState("a", 0), DeviceState::kFree);
  EXPECT_TRUE(manager->cancel(j->id));  // still idempotent
}

TEST_F(ManagerTest, CancelWhileStarting) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  std::string seenState;
  agents.onStart = [&](const Lease& lease) {
    seenState = jobStateName(job(lease.jobId).state);
    auto c = manager->cancel(lease.jobId);
    ASSERT_TRUE(c);
    EXPECT_EQ(c->state, JobState::kCancelling);
  };
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  EXPECT_EQ(seenState, "STARTING");
  EXPECT_EQ(j->state, JobState::kCancelling);
  // One stop from cancel, one more when the start answer came back for a cancelling job.
  EXPECT_EQ(agents.stopsCopy().size(), 2u);
  ASSERT_TRUE(manager->reportExit(j->id, "a", 143, ""));
  EXPECT_EQ(job(j->id).state, JobState::kCancelled);
}

TEST_F(ManagerTest, CancelWhileStartingAndStartFails) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  agents.startError = unavailable("down");
  agents.onStart = [&](const Lease& lease) { ASSERT_TRUE(manager->cancel(lease.jobId)); };
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  EXPECT_EQ(j->state, JobState::kCancelled);
  EXPECT_EQ(deviceState("a", 0), DeviceState::kFree);
}

TEST_F(ManagerTest, CancelFinishedOrUnknown) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  ASSERT_TRUE(manager->reportExit(j->id, "a", 0, ""));
  auto c = manager->cancel(j->id);
  EXPECT_EQ(c.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(c.status().message().find("already SUCCEEDED"), std::string::npos);
  EXPECT_EQ(job(j->id).state, JobState::kSucceeded);  // unchanged
  EXPECT_EQ(manager->cancel("job-999").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(manager->cancel("").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(manager->get("nope").status().code(), StatusCode::kNotFound);
}

TEST_F(ManagerTest, StopNotFoundFinishesACancellingJob) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  agents.stopStatus = notFound("no such job here");
  auto c = manager->cancel(j->id);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->state, JobState::kCancelled);
  EXPECT_EQ(deviceState("a", 0), DeviceState::kFree);
}

// On its last attempt (--max-attempts 1), a job whose node is lost fails with the reason.
TEST_F(ManagerTest, LostNodeFailsAJobOnItsLastAttempt) {
  options.maxAttempts = 1;
  makeManager();
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1)));
  auto ja = manager->submit(submitRequest(10));
  auto jb = manager->submit(submitRequest(10));
  ASSERT_TRUE(ja && jb);
  ASSERT_EQ(ja->devices.front().node, "a");
  ASSERT_EQ(jb->devices.front().node, "b");

  clock.advance(10);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1, 0, 80ull << 30, {jb->id})));
  manager->tick();
  EXPECT_EQ(job(ja->id).state, JobState::kRunning);  // 10 s < 15 s
  clock.advance(6);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1, 0, 80ull << 30, {jb->id})));
  manager->tick();
  const Job lost = job(ja->id);
  EXPECT_EQ(lost.state, JobState::kFailed);
  EXPECT_NE(lost.reason.find("node a lost"), std::string::npos) << lost.reason;
  EXPECT_NE(lost.reason.find("attempt 1 of 1"), std::string::npos) << lost.reason;
  EXPECT_EQ(job(jb->id).state, JobState::kRunning);
  EXPECT_EQ(deviceState("a", 0), DeviceState::kLost);
  bool sawLost = false;
  for (const NodeView& n : manager->nodes())
    if (n.name == "a") sawLost = n.lost;
  EXPECT_TRUE(sawLost);

  // A late exit report for the failed job is accepted and changes nothing.
  EXPECT_TRUE(manager->reportExit(ja->id, "a", 0, ""));
  EXPECT_EQ(job(ja->id).state, JobState::kFailed);
  // The node comes back: its device is free again, and a stray worker is told to stop.
  auto hb = manager->heartbeat(nodeBeat("a", 1, 0, 80ull << 30, {ja->id}));
  ASSERT_TRUE(hb);
  EXPECT_EQ(hb->stopJobs, std::vector<std::string>{ja->id});
  EXPECT_EQ(deviceState("a", 0), DeviceState::kFree);
}

// A lost node puts its jobs back in the queue; they start again, first in the queue, on the next free device; the
// lost node's stray worker is told to stop when the node comes back, and its late exit report is refused.
TEST_F(ManagerTest, LostNodeRequeuesItsJobsOntoFreeDevices) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1)));
  auto ja = manager->submit(submitRequest(10));
  auto jb = manager->submit(submitRequest(10));
  auto jc = manager->submit(submitRequest(10, true));  // queued behind them
  ASSERT_TRUE(ja && jb && jc);
  ASSERT_EQ(ja->devices.front().node, "a");
  EXPECT_EQ(ja->attempts, 1);
  EXPECT_EQ(ja->maxAttempts, 3);
  clock.advance(16);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1, 0, 80ull << 30, {jb->id})));
  manager->tick();
  Job requeued = job(ja->id);
  EXPECT_EQ(requeued.state, JobState::kRequeued);
  EXPECT_NE(requeued.reason.find("node a lost"), std::string::npos) << requeued.reason;
  EXPECT_NE(requeued.reason.find("attempt 1 of 3; requeued"), std::string::npos) << requeued.reason;
  EXPECT_EQ(deviceState("a", 0), DeviceState::kLost);
  EXPECT_EQ(manager->list(true).size(), 3u);  // requeued is active
  // Progress from the lost attempt's worker is answered "stop".
  auto stop = manager->reportProgress(ja->id, {5, 100, 0.05, 1.0, 0, 0}, "");
  ASSERT_TRUE(stop);
  EXPECT_TRUE(*stop);
  // b frees: the requeued job (submitted first) starts there before the queued one.
  ASSERT_TRUE(manager->reportExit(jb->id, "b", 0, ""));
  Job again = job(ja->id);
  EXPECT_EQ(again.state, JobState::kRunning);
  EXPECT_EQ(again.attempts, 2);
  EXPECT_EQ(again.devices.front().node, "b");
  EXPECT_NE(again.reason.find("node a lost"), std::string::npos) << "why attempt 1 ended stays visible";
  EXPECT_EQ(job(jc->id).state, JobState::kQueued);
  // Progress of the first attempt's worker (still alive somewhere) is answered "stop" and not recorded; the second's is.
  auto stale = manager->reportProgress(ja->id, {999, 1000, 0.9, 1.0, 0, 0}, "", 1);
  ASSERT_TRUE(stale);
  EXPECT_TRUE(*stale);
  EXPECT_NE(job(ja->id).progress.step, 999);
  auto current = manager->reportProgress(ja->id, {7, 1000, 0.07, 1.0, 0, 0}, "", 2);
  ASSERT_TRUE(current);
  EXPECT_FALSE(*current);
  EXPECT_EQ(job(ja->id).progress.step, 7);
  // Node a comes back listing the old worker: told to stop; its exit report names a node the job no longer runs on.
  auto hb = manager->heartbeat(nodeBeat("a", 1, 0, 80ull << 30, {ja->id}));
  ASSERT_TRUE(hb);
  EXPECT_EQ(hb->stopJobs, std::vector<std::string>{ja->id});
  EXPECT_EQ(manager->reportExit(ja->id, "a", 137, "").code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(job(ja->id).state, JobState::kRunning);
  EXPECT_EQ(job(jc->id).state, JobState::kRunning);  // on a, free again
}

// Which exits requeue: killed by a signal from outside (137 = SIGKILL) or a service out of reach (2); a simulation's
// own error (3) fails at once. The third failed attempt fails the job.
TEST_F(ManagerTest, KilledWorkersAreRequeuedUntilTheLastAttempt) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  ASSERT_TRUE(manager->reportExit(j->id, "a", 137, "ended by signal 9 (Killed)"));
  EXPECT_EQ(job(j->id).state, JobState::kRunning);  // requeued and started again at once: the device is free
  EXPECT_EQ(job(j->id).attempts, 2);
  EXPECT_EQ(job(j->id).exitCode, 137);
  ASSERT_TRUE(manager->reportExit(j->id, "a", 2, "the back-end at backend:50053 is unreachable"));
  EXPECT_EQ(job(j->id).attempts, 3);
  ASSERT_TRUE(manager->reportExit(j->id, "a", 137, ""));
  const Job failed = job(j->id);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_NE(failed.reason.find("attempt 3 of 3"), std::string::npos) << failed.reason;
  EXPECT_EQ(deviceState("a", 0), DeviceState::kFree);

  auto k = manager->submit(submitRequest(10));
  ASSERT_TRUE(k);
  ASSERT_TRUE(manager->reportExit(k->id, "a", 3, "non-finite velocity of particle 17"));
  EXPECT_EQ(job(k->id).state, JobState::kFailed);
  EXPECT_EQ(job(k->id).attempts, 1);
}

// A requeued job waiting for devices can be cancelled like a queued one.
TEST_F(ManagerTest, CancelRequeued) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  clock.advance(16);
  manager->tick();  // node a lost: nowhere to start again
  ASSERT_EQ(job(j->id).state, JobState::kRequeued);
  auto c = manager->cancel(j->id);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->state, JobState::kCancelled);
}

TEST_F(ManagerTest, LostNodeWhileCancellingCancels) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  agents.stopStatus = unavailable("unreachable");
  ASSERT_TRUE(manager->cancel(j->id));
  EXPECT_EQ(job(j->id).state, JobState::kCancelling);
  clock.advance(16);
  manager->tick();
  EXPECT_EQ(job(j->id).state, JobState::kCancelled);
}

TEST_F(ManagerTest, SpanningJobIsRequeuedWhenAnyOfItsNodesIsLost) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1)));
  auto j = manager->submit(submitRequest(500000));  // 2 GPUs on 2 nodes
  ASSERT_TRUE(j);
  ASSERT_EQ(j->devices.size(), 2u);
  const std::string lead = j->devices[0].node, other = j->devices[1].node;
  clock.advance(16);
  ASSERT_TRUE(manager->heartbeat(nodeBeat(lead, 1, 0, 80ull << 30, {j->id})));
  manager->tick();
  // Requeued, then started again on the device left (fewer GPUs than it deserves, as when fewer exist).
  const Job again = job(j->id);
  EXPECT_EQ(again.state, JobState::kRunning);
  EXPECT_EQ(again.attempts, 2);
  ASSERT_EQ(again.devices.size(), 1u);
  EXPECT_EQ(again.devices[0].node, lead);
  EXPECT_NE(again.reason.find("node " + other + " lost"), std::string::npos);
  ASSERT_FALSE(agents.stopsCopy().empty());  // the lead agent is told to stop the rest
  EXPECT_EQ(agents.stopsCopy().back().address, lead + ":7000");
}

TEST_F(ManagerTest, JobMissingFromItsAgentsHeartbeatsIsRequeued) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));  // does not list it
  clock.advance(10);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  EXPECT_EQ(job(j->id).state, JobState::kRunning);  // within the grace
  clock.advance(6);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  const Job again = job(j->id);
  EXPECT_EQ(again.state, JobState::kRunning);  // requeued, then started again on the device it freed
  EXPECT_EQ(again.attempts, 2);
  EXPECT_NE(again.reason.find("no longer runs the worker"), std::string::npos) << again.reason;
  EXPECT_EQ(agents.startsCopy().size(), 2u);
}

TEST_F(ManagerTest, HeartbeatValidation) {
  HeartbeatInfo hb = nodeBeat("", 1);
  hb.agentAddress.clear();
  auto r = manager->heartbeat(hb);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("node: is empty"), std::string::npos) << r.status().message();
  EXPECT_NE(r.status().message().find("agent_address"), std::string::npos);
  hb = nodeBeat("a", 2);
  hb.devices[1].key.index = 0;
  EXPECT_EQ(manager->heartbeat(hb).status().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(manager->nodes().empty());
  auto ok = manager->heartbeat(nodeBeat("a", 1, 0, 80ull << 30, {"job-unknown"}));
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->heartbeatIntervalSeconds, 2);
  EXPECT_EQ(ok->stopJobs, std::vector<std::string>{"job-unknown"});
}

TEST_F(ManagerTest, ProgressAndExitValidation) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j1 = manager->submit(submitRequest(10));
  auto j2 = manager->submit(submitRequest(10, true));
  ASSERT_TRUE(j1 && j2);
  EXPECT_EQ(manager->reportProgress("job-9", {}, "").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(manager->reportProgress("", {}, "").status().code(), StatusCode::kInvalidArgument);
  Progress bad;
  bad.step = -1;
  EXPECT_EQ(manager->reportProgress(j1->id, bad, "").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(manager->reportProgress(j2->id, {}, "").status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(manager->reportExit(j2->id, "a", 0, "").code(), StatusCode::kFailedPrecondition);
  const Status wrongNode = manager->reportExit(j1->id, "zzz", 0, "");
  EXPECT_EQ(wrongNode.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(wrongNode.message().find("does not run on node 'zzz'"), std::string::npos);
  EXPECT_EQ(manager->reportExit("job-9", "a", 0, "").code(), StatusCode::kNotFound);
  EXPECT_EQ(job(j1->id).state, JobState::kRunning);  // nothing changed
}

TEST_F(ManagerTest, ProgressBecomesWatchEventsWithEta) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  agents.onStart = [&](const Lease&) {};
  auto j = manager->submit(submitRequest(100000));
  ASSERT_TRUE(j);
  std::vector<JobEvent> events;
  auto sub = manager->watch(j->id, [&](const JobEvent& e) { events.push_back(e); });
  ASSERT_TRUE(sub);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].job.state, JobState::kRunning);

  // The worker gives its rate: ETA = remaining steps * particles / rate.
  ASSERT_TRUE(manager->reportProgress(j->id, {200, 1000, 0.2, 1.0, 1e7, 0}, "step 200"));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].message, "step 200");
  EXPECT_EQ(events[1].job.progress.step, 200);
  EXPECT_DOUBLE_EQ(events[1].job.progress.etaSeconds, 800.0 * 100000 / 1e7);

  // Without a rate, the manager measures it between reports: 300 steps in 2 s.
  clock.advance(2);
  ASSERT_TRUE(manager->reportProgress(j->id, {500, 1000, 0.5, 1.0, 0, 0}, ""));
  ASSERT_EQ(events.size(), 3u);
  EXPECT_DOUBLE_EQ(events[2].job.progress.particleStepsPerSecond, 300.0 * 100000 / 2);
  EXPECT_DOUBLE_EQ(events[2].job.progress.etaSeconds, 500.0 * 100000 / (300.0 * 100000 / 2));
  // A worker's own ETA is kept.
  ASSERT_TRUE(manager->reportProgress(j->id, {600, 1000, 0.6, 1.0, 1e7, 42}, ""));
  EXPECT_DOUBLE_EQ(events.back().job.progress.etaSeconds, 42);

  ASSERT_TRUE(manager->reportExit(j->id, "a", 0, ""));
  EXPECT_EQ(events.back().job.state, JobState::kSucceeded);
  const std::size_t n = events.size();
  manager->unwatch(sub.value());
  // Watching a finished job gives it once.
  std::vector<JobEvent> late;
  ASSERT_TRUE(manager->watch(j->id, [&](const JobEvent& e) { late.push_back(e); }));
  ASSERT_EQ(late.size(), 1u);
  EXPECT_EQ(late[0].job.state, JobState::kSucceeded);
  EXPECT_EQ(events.size(), n);
  EXPECT_EQ(manager->watch("job-404", [](const JobEvent&) {}).status().code(), StatusCode::kNotFound);
}

TEST_F(ManagerTest, FirstProgressMovesStartingToRunning) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  JobState during = JobState::kQueued;
  agents.onStart = [&](const Lease& lease) {
    ASSERT_TRUE(manager->reportProgress(lease.jobId, {1, 10, 0, 0, 0, 0}, "hello"));
    during = job(lease.jobId).state;
  };
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  EXPECT_EQ(during, JobState::kRunning);
  EXPECT_EQ(j->state, JobState::kRunning);
  EXPECT_EQ(j->message, "hello");
}

// ---- restart -----------------------------------------------------------------------------------------------------

class ManagerRestartTest : public ManagerTest {
 protected:
  void SetUp() override {
    path = std::filesystem::temp_directory_path() / ("pflow-manager-restart-" + std::to_string(::getpid()) + "-" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db");
    cleanup();
    options.managerAddress = "mgr:50051";
    options.thresholds.particlesPerGpu = 250000;  // the rule under test, not the measured default
    reopen();
  }
  void TearDown() override {
    manager.reset();
    store.reset();
    cleanup();
  }
  void cleanup() {
    std::error_code ec;
    for (const char* ext : {"", "-wal", "-shm"}) std::filesystem::remove(path.string() + ext, ec);
  }
  void reopen() {
    manager.reset();
    store.reset();
    auto s = JobStore::open(path.string());
    ASSERT_TRUE(s) << s.status().toString();
    store = std::move(s.value());
    makeManager();
  }
  std::filesystem::path path;
};

TEST_F(ManagerRestartTest, ReloadsEveryJobStateAndLease) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 2)));
  auto running = manager->submit(submitRequest(10));
  auto cancelling = manager->submit(submitRequest(10));
  auto queued = manager->submit(submitRequest(10, true));
  ASSERT_TRUE(running && cancelling && queued);
  ASSERT_TRUE(manager->reportProgress(running->id, {300, 1000, 0.3, 1.0, 5e6, 0}, "step 300"));
  agents.stopStatus = unavailable("slow");
  ASSERT_TRUE(manager->cancel(cancelling->id));
  auto done = manager->cancel(queued->id);
  ASSERT_TRUE(done);
  auto queued2 = manager->submit(submitRequest(10, true));
  ASSERT_TRUE(queued2);
  const std::vector<Job> before = manager->list(false);

  reopen();
  const std::vector<Job> after = manager->list(false);
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t i = 0; i < after.size(); ++i) {
    EXPECT_EQ(after[i].id, before[i].id);
    EXPECT_EQ(after[i].state, before[i].state) << after[i].id;
    EXPECT_EQ(after[i].reason, before[i].reason);
    EXPECT_EQ(after[i].devices, before[i].devices);
    EXPECT_EQ(after[i].progress.step, before[i].progress.step);
    EXPECT_EQ(after[i].progress.etaSeconds, before[i].progress.etaSeconds);
    EXPECT_EQ(after[i].message, before[i].message);
    EXPECT_EQ(after[i].submittedAt, before[i].submittedAt);
    EXPECT_EQ(after[i].modelUri, before[i].modelUri);
    EXPECT_EQ(after[i].model, before[i].model);  // the least model chosen for the scene (the frontend's text)
    EXPECT_NE(after[i].model.find("tangential history: off"), std::string::npos);
  }
  EXPECT_EQ(job(running->id).state, JobState::kRunning);
  EXPECT_EQ(job(cancelling->id).state, JobState::kCancelling);
  EXPECT_EQ(job(queued->id).state, JobState::kCancelled);
  EXPECT_EQ(job(queued2->id).state, JobState::kQueued);

  // The agent comes back listing both workers: the leases hold, nothing restarts, the queue still waits.
  auto hb = manager->heartbeat(nodeBeat("a", 2, 0, 80ull << 30, {running->id, cancelling->id}));
  ASSERT_TRUE(hb);
  EXPECT_EQ(hb->stopJobs, std::vector<std::string>{cancelling->id});
  std::string h0, h1;
  EXPECT_EQ(deviceState("a", 0, &h0), DeviceState::kBusy);
  EXPECT_EQ(deviceState("a", 1, &h1), DeviceState::kBusy);
  EXPECT_EQ(h0, running->devices[0].index == 0 ? running->id : cancelling->id);
  EXPECT_EQ(job(queued2->id).state, JobState::kQueued);
  clock.advance(30);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 2, 0, 80ull << 30, {running->id, cancelling->id})));
  manager->tick();
  EXPECT_EQ(job(running->id).state, JobState::kRunning);  // re-attached

  // New ids continue after the old ones.
  ASSERT_TRUE(manager->reportExit(running->id, "a", 0, ""));
  EXPECT_EQ(job(queued2->id).state, JobState::kRunning);
  auto next = manager->submit(submitRequest(10, true));
  ASSERT_TRUE(next);
  EXPECT_EQ(next->id, "job-000005");
}

// A job database of schema version 1 (no model column) opens, gains the column, and keeps its jobs.
TEST_F(ManagerRestartTest, MigratesASchemaVersion1Database) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 2)));
  auto running = manager->submit(submitRequest(10));
  ASSERT_TRUE(running);
  manager.reset();
  store.reset();
  const std::string downgrade = "sqlite3 '" + path.string() +
                                "' 'ALTER TABLE jobs DROP COLUMN model; UPDATE schema_info SET version = 1;'";
  if (std::system(downgrade.c_str()) != 0) GTEST_SKIP() << "no sqlite3 command to write a version 1 database";
  reopen();
  EXPECT_EQ(job(running->id).state, JobState::kRunning);
  EXPECT_EQ(job(running->id).model, "");  // written before the column existed
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 2, 0, 80ull << 30, {running->id})));
  auto next = manager->submit(submitRequest(10));
  ASSERT_TRUE(next) << next.status().toString();
  reopen();
  EXPECT_NE(job(next->id).model.find("tangential history"), std::string::npos);
}

TEST_F(ManagerRestartTest, JobIsRequeuedWhenTheAgentDoesNotListIt) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  reopen();
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));  // the agent restarted too and lost its worker
  EXPECT_EQ(job(j->id).state, JobState::kRunning);
  clock.advance(10);
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  EXPECT_EQ(job(j->id).state, JobState::kRunning);  // within the grace
  clock.advance(options.missingJobGraceSeconds - 10);
  manager->tick();
  const Job again = job(j->id);
  EXPECT_EQ(again.state, JobState::kRunning);  // requeued and started again
  EXPECT_EQ(again.attempts, 2);
  EXPECT_NE(again.reason.find("agent on node a no longer runs the worker"), std::string::npos) << again.reason;
  reopen();  // and that is stored
  EXPECT_EQ(job(j->id).attempts, 2);
  EXPECT_EQ(job(j->id).state, JobState::kRunning);
}

TEST_F(ManagerRestartTest, JobIsRequeuedWhenTheAgentNeverComesBack) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto j = manager->submit(submitRequest(10));
  ASSERT_TRUE(j);
  reopen();
  manager->tick();
  EXPECT_EQ(job(j->id).state, JobState::kRunning);
  clock.advance(16);
  manager->tick();
  const Job requeued = job(j->id);
  EXPECT_EQ(requeued.state, JobState::kRequeued);
  EXPECT_NE(requeued.reason.find("node a did not come back within 15.0 s"), std::string::npos) << requeued.reason;
  reopen();  // and that is stored too
  EXPECT_EQ(job(j->id).state, JobState::kRequeued);
  EXPECT_EQ(job(j->id).attempts, 1);
  // A node appears: the requeued job starts there (attempt 2).
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1)));
  EXPECT_EQ(job(j->id).state, JobState::kRunning);
  EXPECT_EQ(job(j->id).attempts, 2);
}

// A job database of schema version 2 (no REQUEUED state, no attempt columns) is rebuilt: a job that had started
// counts one attempt, and REQUEUED can be stored afterwards.
TEST_F(ManagerRestartTest, MigratesASchemaVersion2Database) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto running = manager->submit(submitRequest(10));
  auto queued = manager->submit(submitRequest(10, true));
  ASSERT_TRUE(running && queued);
  manager.reset();
  store.reset();
  const std::string downgrade = "sqlite3 '" + path.string() +
                                "' 'ALTER TABLE jobs DROP COLUMN attempts; ALTER TABLE jobs DROP COLUMN max_attempts; "
                                "UPDATE schema_info SET version = 2;'";
  if (std::system(downgrade.c_str()) != 0) GTEST_SKIP() << "no sqlite3 command to write a version 2 database";
  reopen();
  EXPECT_EQ(job(running->id).attempts, 1);
  EXPECT_EQ(job(queued->id).attempts, 0);
  EXPECT_EQ(job(running->id).devices, running->devices);  // the job's devices and lease survive the rebuild
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1, 0, 80ull << 30, {running->id})));
  std::string holder;
  EXPECT_EQ(deviceState("a", 0, &holder), DeviceState::kBusy);
  EXPECT_EQ(holder, running->id);
  clock.advance(16);
  manager->tick();  // node a silent since: requeued
  EXPECT_EQ(job(running->id).state, JobState::kRequeued);
  reopen();
  EXPECT_EQ(job(running->id).state, JobState::kRequeued);
}

// A job database of schema version 4 (no Slurm columns) gains them and keeps its jobs; a Slurm job id is stored.
TEST_F(ManagerRestartTest, MigratesASchemaVersion4Database) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 1)));
  auto running = manager->submit(submitRequest(10));
  ASSERT_TRUE(running);
  manager.reset();
  store.reset();
  const std::string downgrade = "sqlite3 '" + path.string() +
                                "' 'ALTER TABLE jobs DROP COLUMN slurm_job_id; ALTER TABLE jobs DROP COLUMN slurm_partition; "
                                "ALTER TABLE jobs DROP COLUMN slurm_account; ALTER TABLE jobs DROP COLUMN slurm_time_limit; "
                                "UPDATE schema_info SET version = 4;'";
  if (std::system(downgrade.c_str()) != 0) GTEST_SKIP() << "no sqlite3 command to write a version 4 database";
  reopen();
  Job j = job(running->id);
  EXPECT_EQ(j.state, JobState::kRunning);
  EXPECT_EQ(j.devices, running->devices);
  EXPECT_EQ(j.slurmJobId, "");
  j.slurmJobId = "4711";
  j.slurm = {"gpu", "proj42", "1:00:00"};
  ASSERT_TRUE(store->save(j));
  reopen();
  EXPECT_EQ(job(running->id).slurmJobId, "4711");
  EXPECT_EQ(job(running->id).slurm.timeLimit, "1:00:00");
}

}  // namespace
}  // namespace pflow::manager
