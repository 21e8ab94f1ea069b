// An injectable clock: services read time through it, so timeouts (heartbeats, deadlines) are testable with
// FakeClock. Times are seconds since the Unix epoch (wall clock) as doubles.
#pragma once
#include <atomic>
#include <chrono>

namespace pflow {

class Clock {
 public:
  virtual ~Clock() = default;
  virtual double now() const = 0;  // [s] since the Unix epoch
};

class SystemClock final : public Clock {
 public:
  double now() const override {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  }
};

// For tests: time moves only when told to.
class FakeClock final : public Clock {
 public:
  explicit FakeClock(double start = 1.0e9) : m_now(start) {}
  double now() const override { return m_now.load(); }
  void advance(double seconds) { m_now.store(m_now.load() + seconds); }
  void set(double t) { m_now.store(t); }

 private:
  std::atomic<double> m_now;
};

}  // namespace pflow
