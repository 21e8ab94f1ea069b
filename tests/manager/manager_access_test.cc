// The Manager's rules about who may do what, and the bounds on what it keeps (issue 19), with fakes and a FakeClock:
// owners and admins, deleting finished jobs (their data first), ids never given twice, request fields checked with
// their names, lost nodes forgotten after a while.
#include <gtest/gtest.h>

#include <filesystem>

#include "manager/Manager.h"
#include "tests/agent/AgentTestUtil.h"
#include "tests/manager/Fakes.h"

namespace pflow::manager {
namespace {

using testing::FakeAgentClient;
using testing::FakeFrontendClient;
using testing::FakeJobDataClient;
using testing::nodeBeat;
using testing::submitRequest;

class ManagerAccess : public ::testing::Test {
 protected:
  void SetUp() override { open(); }
  void open() {
    manager.reset();
    store.reset();
    auto s = JobStore::open(m_dir / "jobs.db");
    ASSERT_TRUE(s);
    store = std::move(s.value());
    ManagerOptions options;
    options.heartbeatTimeoutSeconds = 10;
    options.forgetLostNodeSeconds = 60;
    auto m = Manager::create(options, clock, *store, agents, frontend);
    ASSERT_TRUE(m) << m.status().toString();
    manager = std::move(m.value());
    manager->setJobDataClient(&data);
    ASSERT_TRUE(manager->heartbeat(nodeBeat("a", 4)));
  }
  Job submitAs(const std::string& owner, std::uint64_t particles = 10) {
    SubmitRequest r = submitRequest(particles, true);
    r.owner = owner;
    auto j = manager->submit(r);
    EXPECT_TRUE(j) << j.status().toString();
    return j.value();
  }
  Job finished(const std::string& owner) {
    Job j = submitAs(owner);
    EXPECT_TRUE(manager->reportExit(j.id, "a", 0, ""));
    return manager->get(j.id).value();
  }

  agent::testing::TempDir m_dir;
  FakeClock clock{1000};
  FakeAgentClient agents;
  FakeFrontendClient frontend;
  FakeJobDataClient data;
  std::unique_ptr<JobStore> store;
  std::unique_ptr<Manager> manager;
  const Principal alice = Principal::user("alice"), bob = Principal::user("bob"), root = Principal::user("root", true);
};

TEST_F(ManagerAccess, OwnersAndAdminsOnly) {
  const Job j = submitAs("alice");
  EXPECT_TRUE(manager->get(alice, j.id));
  EXPECT_TRUE(manager->get(root, j.id));
  EXPECT_EQ(manager->get(bob, j.id).status().code(), StatusCode::kPermissionDenied);
  EXPECT_EQ(manager->cancel(bob, j.id).status().code(), StatusCode::kPermissionDenied);
  EXPECT_EQ(manager->remove(bob, j.id).code(), StatusCode::kPermissionDenied);
  EXPECT_TRUE(manager->list(bob, false).empty());
  EXPECT_EQ(manager->list(root, false).size(), 1u);
}

TEST_F(ManagerAccess, DeleteRemovesAFinishedJobAndItsDataFirst) {
  const Job running = submitAs("alice");
  EXPECT_EQ(manager->remove(alice, running.id).code(), StatusCode::kFailedPrecondition);  // cancel it first
  EXPECT_TRUE(data.deleted.empty());

  const Job done = finished("alice");
  data.error = unavailable("back-end down");
  EXPECT_EQ(manager->remove(alice, done.id).code(), StatusCode::kUnavailable);
  EXPECT_TRUE(manager->get(done.id));  // kept: its files could not be deleted
  data.error.reset();
  ASSERT_TRUE(manager->remove(alice, done.id));
  EXPECT_EQ(data.deleted.back(), done.id);
  EXPECT_EQ(manager->get(done.id).status().code(), StatusCode::kNotFound);
  open();  // gone from the database too
  EXPECT_EQ(manager->get(done.id).status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(manager->get(running.id));
}

TEST_F(ManagerAccess, IdsAreNeverGivenTwice) {
  ASSERT_TRUE(manager->cancel(submitAs("alice").id));
  const Job last = finished("alice");
  ASSERT_TRUE(manager->remove(root, last.id));  // the newest job
  open();                                       // and a restart
  const Job next = submitAs("alice");
  EXPECT_GT(next.seq, last.seq);
  EXPECT_NE(next.id, last.id);
}

TEST_F(ManagerAccess, RequestFieldsAreCheckedWithTheirNames) {
  SubmitRequest r = submitRequest(10, true);
  r.name = std::string(64 << 20, 'n');  // a 64 MiB name
  r.sceneName = std::string("a\x01\x7f", 3);
  r.files.push_back({std::string(300, 'p'), "x"});
  auto s = manager->submit(r);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.status().code(), StatusCode::kInvalidArgument);
  const std::string& m = s.status().message();
  EXPECT_NE(m.find("name: is 67108864 bytes; the limit is 256"), std::string::npos) << m.substr(0, 500);
  EXPECT_NE(m.find("scene_name: 'a\\x01\\x7f' has characters other than printable ASCII"), std::string::npos) << m.substr(0, 500);
  EXPECT_NE(m.find("files[0].path"), std::string::npos);
  EXPECT_LT(m.size(), 2000u);  // the name is not copied into the message

  for (const std::string& id : {std::string(1 << 20, 'j'), std::string("job\n-1"), std::string()}) {
    auto g = manager->get(id);
    ASSERT_FALSE(g);
    EXPECT_EQ(g.status().code(), StatusCode::kInvalidArgument);
    EXPECT_LT(g.status().message().size(), 200u);
    EXPECT_EQ(manager->reportExit(id, "a", 0, "").code(), StatusCode::kInvalidArgument);
  }
  EXPECT_EQ(manager->reportExit(submitAs("alice").id, "", 0, "").code(), StatusCode::kInvalidArgument);  // which node?
}

TEST_F(ManagerAccess, SubmissionsBuildAfterTheAnswer) {
  SubmitRequest r = submitRequest(10, true);
  r.owner = "alice";
  auto b = manager->beginSubmit(r);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->state, JobState::kBuilding);
  EXPECT_EQ(frontend.builds, 0);  // nothing built yet
  manager->buildSubmitted(b->id, r);
  EXPECT_TRUE(holdsDevices(manager->get(b->id)->state));  // queued, then placed
  EXPECT_EQ(manager->get(b->id)->particles, 10u);

  SubmitRequest bad = r;
  bad.sceneYaml = "invalid";
  auto failed = manager->beginSubmit(bad);
  manager->buildSubmitted(failed->id, bad);
  EXPECT_EQ(manager->get(failed->id)->state, JobState::kFailed);
  EXPECT_NE(manager->get(failed->id)->reason.find("materials[0].density"), std::string::npos);  // the scene's errors

  SubmitRequest huge = r;
  huge.sceneYaml = testing::scene(10) + "memory: 1e15\n";  // fits no device
  auto refused = manager->beginSubmit(huge);
  manager->buildSubmitted(refused->id, huge);
  EXPECT_EQ(manager->get(refused->id)->reason.rfind("refused: ", 0), 0u) << manager->get(refused->id)->reason;

  auto cancelled = manager->beginSubmit(r);
  ASSERT_TRUE(manager->cancel(alice, cancelled->id));
  manager->buildSubmitted(cancelled->id, r);  // the build ends after the cancel: it stays cancelled
  EXPECT_EQ(manager->get(cancelled->id)->state, JobState::kCancelled);

  auto lost = manager->beginSubmit(r);
  open();  // the manager restarts while it builds
  EXPECT_EQ(manager->get(lost->id)->state, JobState::kFailed);
  EXPECT_NE(manager->get(lost->id)->reason.find("submit it again"), std::string::npos);
}

TEST_F(ManagerAccess, LostNodesAreForgottenAfterAWhile) {
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1)));
  const Job j = submitAs("alice");
  clock.advance(11);
  manager->tick();  // both lost: the job is requeued, their devices freed
  auto names = [&] {
    std::vector<std::string> out;
    for (const NodeView& n : manager->nodes()) out.push_back(n.name + (n.lost ? " lost" : ""));
    return out;
  };
  EXPECT_EQ(names(), (std::vector<std::string>{"a lost", "b lost"}));  // listed while recently lost
  EXPECT_EQ(manager->get(j.id)->state, JobState::kRequeued);
  clock.advance(59);
  manager->tick();
  EXPECT_EQ(names().size(), 2u);
  clock.advance(2);
  manager->tick();
  EXPECT_TRUE(names().empty());  // forgotten 60 s after they were lost
  ASSERT_TRUE(manager->heartbeat(nodeBeat("b", 1)));  // a forgotten node comes back with its next heartbeat
  EXPECT_EQ(names(), std::vector<std::string>{"b"});
}

}  // namespace
}  // namespace pflow::manager
