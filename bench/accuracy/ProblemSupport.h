// What the accuracy study's problems share (Problems.cc, AdhesionProblems.cc): a setting applied to a configuration,
// a simulation whose step calls are timed, and a failure recorded from a run's error.
#pragma once
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "bench/accuracy/Problems.h"
#include "compute/dem/TimeStep.h"

namespace pflow::bench::accuracy {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The setting applied to a configuration: every Young's modulus divided by the softening (a rigid wall
// stays rigid), dt = fraction x the Rayleigh time of the softened particles (set as simulation.dt, so
// fractions above 1 are allowed), precision, skin in diameters, rebuild interval, threads.
inline void apply(compute::RunConfig& c, const Setting& s) {
  for (auto& m : c.materials) m.youngsModulus /= s.softening;
  double tr = std::numeric_limits<double>::infinity(), maxR = 0;
  for (std::size_t i = 0; i < c.particles.size(); ++i) {
    const auto& m = c.materials[std::size_t(c.particles.material[i])];
    tr = std::min(tr, compute::rayleighTime(c.particles.radius[i], m.density, m.youngsModulus, m.poissonRatio));
    maxR = std::max(maxR, c.particles.radius[i]);
  }
  c.sim.dt = s.dtFraction * tr;
  c.sim.precision = s.precision;
  c.sim.skin = s.skinFraction * 2 * maxR;
  c.sim.rebuildInterval = s.rebuildInterval;
  c.sim.threads = s.threads;
  if (!(c.sim.duration > 0)) c.sim.duration = 1;
}

// A simulation whose step calls are timed (the measurements between steps are not).
class Timed {
 public:
  Timed(const compute::RunConfig& c, const Setting& s) {
    compute::SimulationOptions o;
    o.executor = s.executor;
    auto r = compute::Simulation::create(c, o);
    if (r) m_sim = std::move(r).value();
    else m_status = r.status();
  }
  bool ok() const { return m_sim && m_status.isOk(); }
  const Status& status() const { return m_status; }
  bool step() {
    const auto t0 = std::chrono::steady_clock::now();
    m_status = m_sim->step();
    m_steps.push_back(float(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()));
    return m_status.isOk();
  }
  compute::Simulation& sim() { return *m_sim; }
  // The cost: the step calls' wall time, each capped at 20x the median step (this machine is shared: a step
  // preempted by another process would otherwise decide the cost of a run of a few steps; a rebuild step
  // costs a few median steps, far below the cap).
  void finish(Outcome& o) const {
    if (!m_sim) return;
    o.steps = m_sim->stepCount();
    const double simTime = double(o.steps) * m_sim->dt();
    std::vector<float> sorted = m_steps;
    double wall = 0;
    if (!sorted.empty()) {
      std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
      const double cap = 20.0 * sorted[sorted.size() / 2];
      for (float d : m_steps) wall += std::min(double(d), cap);
    }
    o.wallPerSimSecond = simTime > 0 ? wall / simTime : kNaN;
  }

 private:
  std::unique_ptr<compute::Simulation> m_sim;
  Status m_status;
  std::vector<float> m_steps;  // wall seconds of each step call
};

inline void failWith(Outcome& o, const Status& s) {
  o.status = classifyError(s.message());
  o.detail = s.message();
}

}  // namespace pflow::bench::accuracy
