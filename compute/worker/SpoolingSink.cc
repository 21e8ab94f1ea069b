#include "compute/worker/SpoolingSink.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <string>
#include <thread>

namespace pflow::worker {

namespace {

std::uint64_t payloadBytes(const compute::ParticleSnapshot& s) {
  std::uint64_t b = 0;
  for (const auto& a : s.arrays) b += a.data.size();
  return b;
}
std::uint64_t payloadBytes(const backend::ProbeSeries& p) {
  std::uint64_t b = p.time.size() * sizeof(double);
  for (const auto& v : p.values) b += v.size() * sizeof(double);
  return b;
}
std::string describe(const compute::ParticleSnapshot& s) { return "snapshot step " + std::to_string(s.step); }
std::string describe(const backend::ProbeSeries& p) { return std::to_string(p.time.size()) + " probe samples"; }
std::string describe(const std::variant<compute::ParticleSnapshot, backend::ProbeSeries>& item) {
  return std::visit([](const auto& x) { return describe(x); }, item);
}

}  // namespace

SpoolingSink::SpoolingSink(std::unique_ptr<SnapshotSink> inner, SpoolOptions options)
    : m_inner(std::move(inner)), m_options(std::move(options)) {
  if (!m_options.sleep) m_options.sleep = [](std::chrono::milliseconds d) { std::this_thread::sleep_for(d); };
  if (!m_options.now) m_options.now = [] { return std::chrono::steady_clock::now(); };
  if (!m_options.stopRequested) m_options.stopRequested = [] { return false; };
  m_options.firstBackoff = std::max(m_options.firstBackoff, std::chrono::milliseconds(1));
  m_options.maxBackoff = std::max(m_options.maxBackoff, m_options.firstBackoff);
}

bool SpoolingSink::retryable(const Status& s) {
  switch (s.code()) {
    case StatusCode::kUnavailable:
    case StatusCode::kDeadlineExceeded:
    case StatusCode::kResourceExhausted:
    case StatusCode::kCancelled:  // the stream cut (the back-end went away mid-snapshot)
    case StatusCode::kIo:
      return true;
    default:
      return false;
  }
}

Status SpoolingSink::deliver(const compute::ParticleSnapshot& snapshot) {
  Status st = m_inner->write(snapshot);
  if (st.code() == StatusCode::kAlreadyExists) return Status::ok();  // an earlier try landed; its answer did not
  return st;
}

Status SpoolingSink::deliver(const backend::ProbeSeries& samples) { return m_inner->writeProbes(samples); }

Status SpoolingSink::deliver(const Item& item) {
  return std::visit([this](const auto& x) { return deliver(x); }, item);
}

bool SpoolingSink::delivered() {
  if (Status st = drain(); !st.isOk()) m_lastFailure = st;
  return m_queue.empty();
}

Status SpoolingSink::drain() {
  while (!m_queue.empty()) {
    Status st = deliver(m_queue.front().first);
    if (!st.isOk()) {
      if (!retryable(st)) return st;
      m_lastFailure = st;
      return Status::ok();
    }
    spdlog::info("back-end: {} delivered from the spool ({} left)", describe(m_queue.front().first), m_queue.size() - 1);
    m_bytes -= m_queue.front().second;
    m_queue.pop_front();
  }
  return Status::ok();
}

Status SpoolingSink::waitForRoom(std::uint64_t bytes, bool all, std::chrono::milliseconds limit, const char* what) {
  std::chrono::milliseconds backoff = m_options.firstBackoff;
  const auto start = m_options.now();
  while (!m_queue.empty() && (all || m_bytes + bytes > m_options.maxBytes)) {
    const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(m_options.now() - start);
    if (m_options.stopRequested())
      return Status(StatusCode::kCancelled, std::string(what) + ": stopped while waiting for the back-end; " + std::to_string(m_queue.size()) +
                                                " outputs unsent (" + describe(m_queue.front().first) + " first)");
    if (waited >= limit)
      return Status(m_lastFailure.code(), std::string(what) + ": the back-end did not answer for " + std::to_string(waited.count() / 1000) +
                                              " s; " + std::to_string(m_queue.size()) + " outputs unsent (" + describe(m_queue.front().first) +
                                              " first); last error: " + m_lastFailure.message());
    spdlog::warn("{}: the spool is full ({} outputs, {} of {} bytes): output paused, retrying in {} ms (back-end: {})", what,
                 m_queue.size(), m_bytes, m_options.maxBytes, backoff.count(), m_lastFailure.message());
    m_options.sleep(backoff);
    backoff = std::min(2 * backoff, m_options.maxBackoff);
    if (Status st = drain(); !st.isOk()) return st;
  }
  return Status::ok();
}

template <class T>
Status SpoolingSink::add(const T& output, std::uint64_t bytes) {
  if (Status st = drain(); !st.isOk()) return st;  // the oldest first
  if (!m_queue.empty() && m_bytes + bytes > m_options.maxBytes) {
    ++m_pauses;
    if (Status st = waitForRoom(bytes, false, std::chrono::milliseconds::max(), "output"); !st.isOk()) return st;
  }
  if (m_queue.empty()) {
    Status st = deliver(output);
    if (st.isOk() || !retryable(st)) return st;
    m_lastFailure = st;
    spdlog::warn("back-end unavailable ({}): {} kept in the spool", st.message(), describe(output));
  }
  m_queue.emplace_back(Item(output), bytes);  // the copy: only what must wait
  m_bytes += bytes;
  return Status::ok();
}

Status SpoolingSink::write(const compute::ParticleSnapshot& snapshot) { return add(snapshot, payloadBytes(snapshot)); }

Status SpoolingSink::writeProbes(const backend::ProbeSeries& samples) { return add(samples, payloadBytes(samples)); }

Status SpoolingSink::close() {
  if (Status st = drain(); !st.isOk()) return st;
  // Everything must go: wait as for room for the whole spool.
  if (Status st = waitForRoom(0, true, m_options.closeWait, "close"); !st.isOk()) return st;
  return m_inner->close();
}

}  // namespace pflow::worker
