// The job state machine (every legal and illegal transition) and the SQLite store.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <set>

#include "manager/JobStore.h"
#include "manager/JobTable.h"

namespace pflow::manager {
namespace {

constexpr JobState kAll[] = {JobState::kQueued,    JobState::kStarting,   JobState::kRunning,  JobState::kSucceeded,
                             JobState::kFailed,    JobState::kCancelling, JobState::kCancelled, JobState::kRequeued};

TEST(JobTable, EveryTransition) {
  using S = JobState;
  const std::set<std::pair<S, S>> legal{
      {S::kQueued, S::kStarting},     {S::kQueued, S::kCancelled},     {S::kStarting, S::kRunning},
      {S::kStarting, S::kSucceeded},  {S::kStarting, S::kFailed},      {S::kStarting, S::kCancelling},
      {S::kRunning, S::kSucceeded},   {S::kRunning, S::kFailed},       {S::kRunning, S::kCancelling},
      {S::kCancelling, S::kCancelled}, {S::kStarting, S::kRequeued},   {S::kRunning, S::kRequeued},
      {S::kRequeued, S::kStarting},   {S::kRequeued, S::kCancelled}};
  int checked = 0;
  for (S from : kAll) {
    for (S to : kAll) {
      const bool want = legal.count({from, to}) > 0;
      EXPECT_EQ(JobTable::isLegal(from, to), want) << jobStateName(from) << " -> " << jobStateName(to);
      Job j;
      j.id = "job-1";
      j.state = from;
      const Status s = JobTable::transition(j, to, "why", 5.0);
      EXPECT_EQ(s.isOk(), want);
      if (want) {
        EXPECT_EQ(j.state, to);
      } else {
        EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
        EXPECT_NE(s.message().find(std::string(jobStateName(from)) + " to " + jobStateName(to)), std::string::npos);
        EXPECT_EQ(j.state, from);  // unchanged
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, 64);
}

TEST(JobTable, TimestampsAndReason) {
  Job j;
  j.id = "job-1";
  ASSERT_TRUE(JobTable::transition(j, JobState::kStarting, "", 10.0));
  EXPECT_EQ(j.startedAt, 10.0);
  ASSERT_TRUE(JobTable::transition(j, JobState::kRunning, "", 11.0));
  EXPECT_EQ(j.startedAt, 10.0);
  EXPECT_EQ(j.finishedAt, 0.0);
  ASSERT_TRUE(JobTable::transition(j, JobState::kFailed, "node a lost", 20.0));
  EXPECT_EQ(j.finishedAt, 20.0);
  EXPECT_EQ(j.reason, "node a lost");
  EXPECT_TRUE(isFinal(j.state));
}

// Each start counts an attempt and stamps startedAt; a requeue keeps the count; the requeued job waits in the queue
// in its submission order.
TEST(JobTable, AttemptsAndTheRequeuedQueue) {
  Job j;
  j.id = "job-1";
  ASSERT_TRUE(JobTable::transition(j, JobState::kStarting, "", 1.0));
  EXPECT_EQ(j.attempts, 1);
  ASSERT_TRUE(JobTable::transition(j, JobState::kRunning, "", 2.0));
  ASSERT_TRUE(JobTable::transition(j, JobState::kRequeued, "node a lost", 3.0));
  EXPECT_EQ(j.attempts, 1);
  EXPECT_FALSE(holdsDevices(j.state));
  EXPECT_FALSE(isFinal(j.state));
  EXPECT_TRUE(isWaiting(j.state));
  ASSERT_TRUE(JobTable::transition(j, JobState::kStarting, "", 4.0));
  EXPECT_EQ(j.attempts, 2);
  EXPECT_EQ(j.startedAt, 4.0);
  EXPECT_EQ(j.finishedAt, 0.0);

  JobTable t;
  Job a, b;
  a.seq = 1, a.id = "job-a", a.state = JobState::kRequeued;
  b.seq = 2, b.id = "job-b", b.state = JobState::kQueued;
  t.put(b);
  t.put(a);
  const auto q = t.queued();
  ASSERT_EQ(q.size(), 2u);
  EXPECT_EQ(q[0]->id, "job-a");
  EXPECT_EQ(q[1]->id, "job-b");
  EXPECT_EQ(t.list(true).size(), 2u);
}

TEST(JobTable, ListsInSubmissionOrderAndQueue) {
  JobTable t;
  for (int i = 3; i >= 1; --i) {
    Job j;
    j.seq = i;
    j.id = "job-" + std::to_string(i);
    j.state = i == 2 ? JobState::kSucceeded : JobState::kQueued;
    t.put(j);
  }
  const auto all = t.list(false);
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].id, "job-1");
  EXPECT_EQ(all[2].id, "job-3");
  EXPECT_EQ(t.list(true).size(), 2u);
  const auto q = t.queued();
  ASSERT_EQ(q.size(), 2u);
  EXPECT_EQ(q[0]->id, "job-1");
  EXPECT_EQ(t.maxSeq(), 3);
}

struct TempDb {
  std::filesystem::path path = std::filesystem::temp_directory_path() /
                               ("pflow-jobstore-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".db");
  ~TempDb() {
    std::error_code ec;
    for (const char* ext : {"", "-wal", "-shm"}) std::filesystem::remove(path.string() + ext, ec);
  }
  static inline int counter = 0;
};

Job sampleJob() {
  Job j;
  j.seq = 7;
  j.id = "job-000007";
  j.name = "hopper";
  j.state = JobState::kRunning;
  j.reason = "";
  j.sceneName = "hopper.yaml";
  j.modelId = "abc123";
  j.modelUri = "/models/abc123";
  j.particles = 1234567;
  j.memoryBytes = 2.5e9;
  j.maxDevices = 3;
  j.wait = true;
  j.devices = {{"b", 1, DeviceKind::kGpu}, {"a", 0, DeviceKind::kGpu}};
  j.submittedAt = 100.5;
  j.startedAt = 101.25;
  j.progress = {500, 1000, 0.5, 1.0, 2.5e7, 12.0};
  j.progressAt = 110.0;
  j.message = "executor: CUDA";
  j.exitCode = 0;
  j.attempts = 2;
  j.maxAttempts = 3;
  return j;
}

TEST(JobStore, RoundTripsEveryFieldAndLease) {
  TempDb db;
  {
    auto store = JobStore::open(db.path.string());
    ASSERT_TRUE(store) << store.status().toString();
    ASSERT_TRUE((*store)->save(sampleJob()));
    Job q;
    q.seq = 8;
    q.id = "job-000008";
    q.state = JobState::kQueued;
    ASSERT_TRUE((*store)->save(q));
  }
  auto store = JobStore::open(db.path.string());
  ASSERT_TRUE(store);
  auto jobs = (*store)->loadAll();
  ASSERT_TRUE(jobs);
  ASSERT_EQ(jobs->size(), 2u);
  const Job& j = jobs->front();
  const Job want = sampleJob();
  EXPECT_EQ(j.id, want.id);
  EXPECT_EQ(j.seq, want.seq);
  EXPECT_EQ(j.name, want.name);
  EXPECT_EQ(j.state, want.state);
  EXPECT_EQ(j.sceneName, want.sceneName);
  EXPECT_EQ(j.modelId, want.modelId);
  EXPECT_EQ(j.modelUri, want.modelUri);
  EXPECT_EQ(j.attempts, 2);
  EXPECT_EQ(j.maxAttempts, 3);
  EXPECT_EQ(j.particles, want.particles);
  EXPECT_EQ(j.memoryBytes, want.memoryBytes);
  EXPECT_EQ(j.maxDevices, want.maxDevices);
  EXPECT_EQ(j.wait, want.wait);
  EXPECT_EQ(j.devices, want.devices);
  EXPECT_EQ(j.submittedAt, want.submittedAt);
  EXPECT_EQ(j.startedAt, want.startedAt);
  EXPECT_EQ(j.progress.step, 500);
  EXPECT_EQ(j.progress.totalSteps, 1000);
  EXPECT_EQ(j.progress.particleStepsPerSecond, 2.5e7);
  EXPECT_EQ(j.progress.etaSeconds, 12.0);
  EXPECT_EQ(j.progressAt, 110.0);
  EXPECT_EQ(j.message, want.message);
  auto leases = (*store)->leases();
  ASSERT_TRUE(leases);
  ASSERT_EQ(leases->size(), 2u);
  EXPECT_EQ((*leases)[0].second, "job-000007");
}

TEST(JobStore, FinishedJobsKeepDevicesButReleaseLeases) {
  auto store = JobStore::open(":memory:");
  ASSERT_TRUE(store);
  Job j = sampleJob();
  ASSERT_TRUE((*store)->save(j));
  j.state = JobState::kSucceeded;
  ASSERT_TRUE((*store)->save(j));
  EXPECT_TRUE((*store)->leases()->empty());
  EXPECT_EQ((*store)->loadAll()->front().devices.size(), 2u);
}

TEST(JobStore, RefusesTwoLiveLeasesOnOneDeviceAndChangesNothing) {
  auto store = JobStore::open(":memory:");
  ASSERT_TRUE(store);
  ASSERT_TRUE((*store)->save(sampleJob()));
  Job other = sampleJob();
  other.seq = 9;
  other.id = "job-000009";
  const Status s = (*store)->save(other);
  EXPECT_EQ(s.code(), StatusCode::kIo);
  EXPECT_EQ((*store)->loadAll()->size(), 1u);  // the transaction rolled back
}

TEST(JobStore, BadPathIsAnIoError) {
  auto store = JobStore::open("/nonexistent-dir/x/y.db");
  EXPECT_FALSE(store);
  EXPECT_EQ(store.status().code(), StatusCode::kIo);
}

}  // namespace
}  // namespace pflow::manager
