// A worker's output while the back-end is away (issue 18, "Back-end outages"): SpoolingSink wraps the sink that
// talks to the back-end and keeps, in order, every snapshot and probe series it could not deliver in a spool
// bounded in bytes. Each later output first retries what the spool holds (oldest first); nothing is dropped while
// the spool has room. When a new output does not fit, output pauses: the call waits, retrying with a backoff that
// doubles up to a ceiling and logging what it waits for, until the back-end takes enough. close() waits the same
// way, up to SpoolOptions::closeWait, and only then fails with the steps it could not deliver.
//
// Only outages are waited out (SpoolingSink::retryable: unavailable, deadline exceeded, resources exhausted such
// as a full disk, a stream cut, an I/O error); any other error is the job's and returns at once. A snapshot the
// back-end reports as already stored (a retry of one whose answer was lost) counts as delivered. A probe append
// whose answer was lost is sent again and its samples are stored twice (the back-end has no identity for them).
#pragma once
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <variant>

#include "compute/worker/SnapshotSinks.h"

namespace pflow::worker {

struct SpoolOptions {
  std::uint64_t maxBytes = std::uint64_t(1) << 30;  // what the spool may hold (snapshot and probe payloads)
  std::chrono::milliseconds firstBackoff{500}, maxBackoff{30000};
  std::chrono::milliseconds closeWait{std::chrono::minutes(10)};  // close(): how long to wait for the back-end
  // How a pause waits and measures its wait (tests replace both with a clock of their own).
  std::function<void(std::chrono::milliseconds)> sleep;
  std::function<std::chrono::steady_clock::time_point()> now;
  // A pause ends when this says the worker must stop (SIGTERM from its agent): the output then fails as cancelled.
  std::function<bool()> stopRequested;
};

class SpoolingSink final : public SnapshotSink {
 public:
  SpoolingSink(std::unique_ptr<SnapshotSink> inner, SpoolOptions options);
  Status writeGeometry(compute::GeometrySnapshot geometry) override { return m_inner->writeGeometry(std::move(geometry)); }
  Status write(const compute::ParticleSnapshot& snapshot) override;
  Status writeProbes(const backend::ProbeSeries& samples) override;
  Status close() override;
  // Tries the spool (oldest first) and says whether it is empty now.
  bool delivered() override;

  static bool retryable(const Status& s);
  std::size_t spooled() const { return m_queue.size(); }
  std::uint64_t spooledBytes() const { return m_bytes; }
  std::uint64_t pauses() const { return m_pauses; }  // outputs that had to wait for room

 private:
  using Item = std::variant<compute::ParticleSnapshot, backend::ProbeSeries>;
  // An output delivered at once when nothing waits before it; copied into the spool only when it must wait.
  template <class T>
  Status add(const T& output, std::uint64_t bytes);
  Status deliver(const compute::ParticleSnapshot& snapshot);
  Status deliver(const backend::ProbeSeries& samples);
  Status deliver(const Item& item);
  // Sends the spool's items, oldest first, until it is empty or the back-end fails again (OK then: they stay).
  Status drain();
  // Waits (with the backoff) until the spool has `bytes` of room (`all`: until it is empty), at most `limit` in all.
  Status waitForRoom(std::uint64_t bytes, bool all, std::chrono::milliseconds limit, const char* what);

  std::unique_ptr<SnapshotSink> m_inner;
  SpoolOptions m_options;
  std::deque<std::pair<Item, std::uint64_t>> m_queue;
  std::uint64_t m_bytes = 0, m_pauses = 0;
  Status m_lastFailure;
};

}  // namespace pflow::worker
