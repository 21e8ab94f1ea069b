// SpoolingSink (issue 18, "Back-end outages"; labels unit and fault): a worker's output while the back-end is away,
// against a fake back-end sink that is down for a while. Nothing is dropped, order is kept, a full spool pauses
// output instead of failing the job, and only outages are waited out.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "compute/worker/SpoolingSink.h"

namespace pflow::worker {
namespace {

// The back-end as the worker sees it: down (`failWith`) for the next `downFor` calls, then up; records what it took.
struct FakeBackend final : SnapshotSink {
  int downFor = 0;
  Status failWith{StatusCode::kUnavailable, "connection refused"};
  std::vector<std::string> stored;  // "snapshot 10", "probes 3"
  int calls = 0;
  bool closed = false;
  Status take(std::string what) {
    ++calls;
    if (downFor > 0) {
      --downFor;
      return failWith;
    }
    stored.push_back(std::move(what));
    return Status::ok();
  }
  Status writeGeometry(compute::GeometrySnapshot) override { return Status::ok(); }
  const compute::ParticleSnapshot* lastSeen = nullptr;  // the object write() was given (a copy or the caller's)
  Status write(const compute::ParticleSnapshot& s) override {
    lastSeen = &s;
    return take("snapshot " + std::to_string(s.step));
  }
  Status writeProbes(const backend::ProbeSeries& p) override { return take("probes " + std::to_string(p.time.size())); }
  Status close() override {
    closed = true;
    return Status::ok();
  }
};

compute::ParticleSnapshot snapshot(std::int64_t step, std::size_t bytes = 1000) {
  compute::ParticleSnapshot s;
  s.step = step;
  s.n = 1;
  s.arrays.push_back({"position", compute::ScalarType::kF64, 1, "m", std::vector<std::byte>(bytes)});
  return s;
}

struct Fixture {
  FakeBackend* backend = nullptr;
  std::unique_ptr<SpoolingSink> sink;
  std::vector<long> slept;  // [ms]
  std::chrono::steady_clock::time_point clock{};  // moved on by the pauses only
  bool stop = false;
  explicit Fixture(std::uint64_t maxBytes) {
    auto b = std::make_unique<FakeBackend>();
    backend = b.get();
    SpoolOptions o;
    o.maxBytes = maxBytes;
    o.firstBackoff = std::chrono::milliseconds(100);
    o.maxBackoff = std::chrono::milliseconds(800);
    o.closeWait = std::chrono::milliseconds(5000);
    o.sleep = [this](std::chrono::milliseconds d) {
      slept.push_back(long(d.count()));
      clock += d;
    };
    o.now = [this] { return clock; };
    o.stopRequested = [this] { return stop; };
    sink = std::make_unique<SpoolingSink>(std::move(b), o);
  }
};

// The back-end is down for three snapshot intervals, then back: every snapshot is stored, in order, with no pause
// (the spool had room), and the job never saw an error.
TEST(SpoolingSink, BackEndDownForThreeIntervalsLosesNothing) {
  Fixture f(1 << 20);
  f.backend->downFor = 3;  // the attempts at steps 10, 20 and 30 fail
  for (int step = 10; step <= 60; step += 10) ASSERT_TRUE(f.sink->write(snapshot(step)).isOk()) << step;
  ASSERT_TRUE(f.sink->close().isOk());
  EXPECT_EQ(f.backend->stored, (std::vector<std::string>{"snapshot 10", "snapshot 20", "snapshot 30", "snapshot 40", "snapshot 50", "snapshot 60"}));
  EXPECT_TRUE(f.slept.empty());
  EXPECT_EQ(f.sink->spooled(), 0u);
  EXPECT_TRUE(f.backend->closed);
}

// delivered() (asked before a checkpoint is sent) tries the spool and is true only when nothing waits in it: the
// chaos run that lost a snapshot had its checkpoint of that step reach the back-end while the snapshot was still
// spooled, then the worker died with its spool and the resumed run began after that snapshot.
TEST(SpoolingSink, DeliveredOnlyWhenTheSpoolIsEmpty) {
  Fixture f(1 << 20);
  EXPECT_TRUE(f.sink->delivered());
  f.backend->downFor = 2;  // the write and the first retry fail
  ASSERT_TRUE(f.sink->write(snapshot(10)).isOk());
  EXPECT_FALSE(f.sink->delivered());
  EXPECT_EQ(f.sink->spooled(), 1u);
  EXPECT_TRUE(f.sink->delivered());  // the back-end is back: the spool drains now
  EXPECT_EQ(f.backend->stored, (std::vector<std::string>{"snapshot 10"}));
}

// With the back-end up and nothing waiting, a snapshot goes through as the caller's object (a snapshot may be
// hundreds of MB: only what must wait is copied into the spool).
TEST(SpoolingSink, NoCopyWhenNothingWaits) {
  Fixture f(1 << 20);
  const compute::ParticleSnapshot s = snapshot(3);
  ASSERT_TRUE(f.sink->write(s).isOk());
  EXPECT_EQ(f.backend->lastSeen, &s);
  f.backend->downFor = 1;
  ASSERT_TRUE(f.sink->write(snapshot(4)).isOk());  // spooled: a copy
  ASSERT_TRUE(f.sink->close().isOk());
  EXPECT_EQ(f.backend->stored, (std::vector<std::string>{"snapshot 3", "snapshot 4"}));
}

// Probe series and snapshots share one queue: the back-end receives them in the order they were written.
TEST(SpoolingSink, ProbesAndSnapshotsKeepTheirOrder) {
  Fixture f(1 << 20);
  f.backend->downFor = 2;
  backend::ProbeSeries p;
  p.add(0.1, {1.0});
  p.add(0.2, {2.0});
  ASSERT_TRUE(f.sink->writeProbes(p).isOk());
  ASSERT_TRUE(f.sink->write(snapshot(5)).isOk());
  EXPECT_EQ(f.sink->spooled(), 2u);
  ASSERT_TRUE(f.sink->write(snapshot(6)).isOk());
  ASSERT_TRUE(f.sink->close().isOk());
  EXPECT_EQ(f.backend->stored, (std::vector<std::string>{"probes 2", "snapshot 5", "snapshot 6"}));
}

// A full spool pauses output: the write waits (backoff 100, 200, 400, 800, 800 ms) until the back-end takes the
// oldest, then goes on; nothing is refused.
TEST(SpoolingSink, FullSpoolPausesOutputUntilTheBackEndReturns) {
  Fixture f(2500);  // two snapshots of 1000 bytes fit, a third does not
  f.backend->downFor = 8;
  ASSERT_TRUE(f.sink->write(snapshot(1)).isOk());  // fails, spooled (1 call)
  ASSERT_TRUE(f.sink->write(snapshot(2)).isOk());  // drain fails (2), spooled
  ASSERT_TRUE(f.sink->write(snapshot(3)).isOk());  // drain fails (3), no room: waits, drains at each try (4..8 fail), then 9 succeeds
  EXPECT_EQ(f.sink->pauses(), 1u);
  EXPECT_EQ(f.slept, (std::vector<long>{100, 200, 400, 800, 800, 800}));
  ASSERT_TRUE(f.sink->close().isOk());
  EXPECT_EQ(f.backend->stored, (std::vector<std::string>{"snapshot 1", "snapshot 2", "snapshot 3"}));
}

// An error that is not an outage is the job's: returned at once, nothing spooled; "already stored" (a retry of a
// snapshot whose answer was lost) counts as delivered.
TEST(SpoolingSink, OnlyOutagesAreWaitedOut) {
  Fixture f(1 << 20);
  f.backend->downFor = 1;
  f.backend->failWith = Status(StatusCode::kInvalidArgument, "bad array");
  EXPECT_EQ(f.sink->write(snapshot(1)).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(f.sink->spooled(), 0u);
  f.backend->downFor = 1;
  f.backend->failWith = Status(StatusCode::kAlreadyExists, "step 2 is stored");
  ASSERT_TRUE(f.sink->write(snapshot(2)).isOk());
  EXPECT_EQ(f.sink->spooled(), 0u);
  for (StatusCode c : {StatusCode::kUnavailable, StatusCode::kDeadlineExceeded, StatusCode::kResourceExhausted, StatusCode::kCancelled,
                       StatusCode::kIo})
    EXPECT_TRUE(SpoolingSink::retryable(Status(c, ""))) << statusCodeName(c);
  for (StatusCode c : {StatusCode::kInvalidArgument, StatusCode::kNotFound, StatusCode::kInternal, StatusCode::kFailedPrecondition})
    EXPECT_FALSE(SpoolingSink::retryable(Status(c, ""))) << statusCodeName(c);
}

// A back-end that never returns: close() waits its closeWait (5 s here) and then fails the job, naming what was not
// delivered and the back-end's last error.
TEST(SpoolingSink, CloseGivesUpAfterItsWaitWithTheReason) {
  Fixture f(1 << 20);
  f.backend->downFor = 1000000;
  ASSERT_TRUE(f.sink->write(snapshot(7)).isOk());
  ASSERT_TRUE(f.sink->write(snapshot(8)).isOk());
  const Status s = f.sink->close();
  ASSERT_FALSE(s.isOk());
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_NE(s.message().find("2 outputs unsent (snapshot step 7 first)"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("connection refused"), std::string::npos) << s.message();
  long total = 0;
  for (long d : f.slept) total += d;
  EXPECT_GE(total, 5000);
  EXPECT_LT(total, 5000 + 800);
  EXPECT_FALSE(f.backend->closed);
}

// A worker told to stop (SIGTERM from its agent) while its output is paused stops waiting: the output fails as
// cancelled, naming what was not sent.
TEST(SpoolingSink, StopEndsAPause) {
  Fixture f(1500);
  f.backend->downFor = 1000000;
  ASSERT_TRUE(f.sink->write(snapshot(1)).isOk());
  f.stop = true;
  const Status s = f.sink->write(snapshot(2));
  EXPECT_EQ(s.code(), StatusCode::kCancelled) << s.message();
  EXPECT_NE(s.message().find("snapshot step 1 first"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace pflow::worker
