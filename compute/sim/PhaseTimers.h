// Wall-clock time per phase of the step loop.
#pragma once
#include <array>
#include <chrono>
#include <functional>
#include <string>

namespace pflow::compute {

// migrate and halo: distributed runs only (particles changing rank at rebuilds; ghosts).
enum class Phase { kIntegrate1, kMeshes, kMigrate, kSort, kHalo, kContacts, kForces, kIntegrate2, kOutput, kCount };
inline constexpr const char* kPhaseNames[] = {"integrate1", "meshes", "migrate", "sort", "halo", "contacts", "forces", "integrate2", "output"};

inline Phase phaseByName(const std::string& name) {
  for (int p = 0; p < int(Phase::kCount); ++p)
    if (name == kPhaseNames[p]) return Phase(p);
  return Phase::kCount;
}

class PhaseTimers {
 public:
  class Scope {
   public:
    Scope(PhaseTimers& t, Phase p, bool fenced = true)
        : m_t(t), m_p(p), m_fenced(fenced), m_start(std::chrono::steady_clock::now()) {}
    ~Scope() {
      if (m_fenced && m_t.m_fence) m_t.m_fence();
      m_t.m_seconds[int(m_p)] += std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    }
   private:
    PhaseTimers& m_t;
    Phase m_p;
    bool m_fenced;
    std::chrono::steady_clock::time_point m_start;
  };
  Scope time(Phase p) { return Scope(*this, p); }
  // Times the host's part only: the device's queued work goes on (and is counted by the next fenced phase).
  Scope timeUnfenced(Phase p) { return Scope(*this, p, false); }
  double seconds(Phase p) const { return p == Phase::kCount ? 0.0 : m_seconds[int(p)]; }
  double total() const {
    double s = 0;
    for (double v : m_seconds) s += v;
    return s;
  }
  void reset() { m_seconds.fill(0); }
  // Called at the end of each timed phase: an asynchronous executor waits there for its queued work,
  // so each phase's time is its own.
  void setFence(std::function<void()> fence) { m_fence = std::move(fence); }
  // "PERFORMANCE integrate1 0.12 s (3.1 %) ..." one line.
  std::string report() const;

 private:
  std::array<double, int(Phase::kCount)> m_seconds{};
  std::function<void()> m_fence;
};

}  // namespace pflow::compute
