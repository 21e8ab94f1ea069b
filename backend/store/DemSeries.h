// A DEM run's time series (docs/output-format.md, "Series"), kept in the same form and file group as an SPH run's
// probes (/probes: time, then one dataset per series with its unit and point) so every path that stores, streams,
// fetches and draws probes carries them too (`pflow fetch` writes them as CSV; `pflow plot` draws them):
//   kinetic_energy [J]        translational plus rotational, every particle
//   contacts                  particle pairs in contact (a pair across two ranks of a distributed run counts on each)
//   wall_contacts             particle-wall contacts
//   coordination              2 x contacts / particles
//   mass_past:<plane> [kg]    the mass of the particles whose centre lies past output.flow_planes' <plane> (on the
//                             side its normal points to); its growth is the mass flow through the plane
//   force_x:<surface> .. force_z:<surface> [N], torque_x:<surface> .. torque_z:<surface> [N m]
//                             the load of the particles' contacts on each wall surface (planes and mesh triangles by
//                             surface number; a '/' in its name becomes '.'), force and torque about the origin (about p: T - p x F), summed during
//                             the forces of the sampled step itself (Simulation::recordWallLoads); the start's
//                             sample, taken before any step, has none (NaN)
//   wall_position:<mesh> [m], wall_velocity:<mesh> [m/s], drive_force:<mesh> [N]
//                             a wall driven along a guide (motion.drive with a mass): its displacement and velocity
//                             along the guide since the start, and the force its drive applied at the sampled step
//   wall_angle:<mesh> [rad], wall_angular_velocity:<mesh> [rad/s], drive_torque:<mesh> [N m]
//                             the same for a wall driven about an axis (motion.drive with a moment of inertia)
// A series' point is the flow plane's point, or NaN for the global ones. Sampled at the start, then every
// output.series_interval of simulated time (the first step at or past each multiple), or at every snapshot when
// none is given. Sampling is collective in a distributed run: every rank calls sample() after every step.
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "backend/store/ProbeSeries.h"
#include "compute/sim/RunConfig.h"

namespace pflow::backend {

class DemSeriesRecorder {
 public:
  // Sim: compute::Simulation; Domain: compute::Domain (sums over ranks). A template: no link dependency.
  // Surface names by number (RunConfig::surfaceNames; "" or missing: "surface N"). The recorder tells `sim` to sum
  // the wall loads on the steps it samples.
  template <class Sim, class Domain>
  DemSeriesRecorder(Sim& sim, Domain& domain, const compute::SeriesConfig& config, const std::vector<std::string>& surfaces = {})
      : m_config(config), m_lastTime(sim.time()) {
    sim.recordWallLoads(config.interval <= 0, config.interval);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto add = [&](const std::string& name, const char* unit, Vec3d point) {
      m_series.names.push_back(name);
      m_series.units.push_back(unit);
      m_series.points.push_back(point);
    };
    add("kinetic_energy", "J", {nan, nan, nan});
    add("contacts", "", {nan, nan, nan});
    add("wall_contacts", "", {nan, nan, nan});
    add("coordination", "", {nan, nan, nan});
    for (const auto& p : config.flowPlanes) add("mass_past:" + p.name, "kg", p.point);
    m_surfaces = sim.wallLoads().size() / 6;
    for (std::size_t k = 0; k < m_surfaces; ++k) {
      std::string name = k < surfaces.size() && !surfaces[k].empty() ? surfaces[k] : "surface " + std::to_string(k);
      std::replace(name.begin(), name.end(), '/', '.');  // an HDF5 name has no '/': bin/bottom -> bin.bottom
      for (const char* axis : {"x", "y", "z"}) add(std::string("force_") + axis + ":" + name, "N", {nan, nan, nan});
      for (const char* axis : {"x", "y", "z"}) add(std::string("torque_") + axis + ":" + name, "N m", {nan, nan, nan});
    }
    for (const auto& w : sim.wallDrives().walls()) {
      std::string name = w.name;
      std::replace(name.begin(), name.end(), '/', '.');
      if (w.drive.translates()) {
        add("wall_position:" + name, "m", {nan, nan, nan});
        add("wall_velocity:" + name, "m/s", {nan, nan, nan});
        add("drive_force:" + name, "N", {nan, nan, nan});
      }
      if (w.drive.rotates()) {
        add("wall_angle:" + name, "rad", {nan, nan, nan});
        add("wall_angular_velocity:" + name, "rad/s", {nan, nan, nan});
        add("drive_torque:" + name, "N m", {nan, nan, nan});
      }
    }
    m_series.add(sim.time(), values(sim, domain));
  }

  template <class Sim, class Domain>
  void sample(const Sim& sim, Domain& domain) {
    // simulation.on_instability: reduce_dt went back to an earlier state: the samples of the abandoned stretch go
    // (those already stored stay: a file or the back-end keeps the first sample of each time).
    const double now = sim.time();
    if (!m_series.time.empty() && m_series.time.back() > now + 1e-12 * std::max(1.0, std::abs(now))) {
      while (!m_series.time.empty() && m_series.time.back() > now + 1e-12 * std::max(1.0, std::abs(now))) {
        m_series.time.pop_back();
        for (auto& v : m_series.values) v.pop_back();
      }
      m_lastTime = now;
    }
    const bool due = m_config.interval > 0 ? compute::seriesSampleDue(m_lastTime, now, m_config.interval) : sim.outputDue();
    m_lastTime = now;
    if (due) m_series.add(now, values(sim, domain));
  }

  const ProbeSeries& series() const { return m_series; }

 private:
  template <class Sim, class Domain>
  std::vector<double> values(const Sim& sim, Domain& domain) const {
    const auto stats = sim.contactStats();  // host copies: once a sample
    const double particles = domain.sum(double(sim.numParticles()));
    const double pairs = domain.sum(double(stats.particleContacts));
    std::vector<double> v = {domain.sum(stats.kineticEnergy), pairs, domain.sum(double(stats.wallContacts)),
                             particles > 0 ? 2 * pairs / particles : 0.0};
    for (const auto& p : m_config.flowPlanes) v.push_back(domain.sum(sim.engine().massPastPlane(p.point, p.normal)));
    if (m_surfaces > 0) {
      const bool fresh = sim.wallLoadsStep() == sim.stepCount();  // summed during this very step
      const std::vector<double> loads = sim.wallLoads();
      for (std::size_t k = 0; k < 6 * m_surfaces; ++k) {
        const double local = fresh && k < loads.size() ? loads[k] : 0.0;
        const double total = domain.sum(local);  // collective on every rank alike
        v.push_back(fresh ? total : std::numeric_limits<double>::quiet_NaN());
      }
    }
    for (const auto& w : sim.wallDrives().walls()) {  // the same on every rank
      if (w.drive.translates()) v.insert(v.end(), {w.s, w.v, w.driveForce});
      if (w.drive.rotates()) v.insert(v.end(), {w.theta, w.omega, w.driveTorque});
    }
    return v;
  }

  compute::SeriesConfig m_config;
  ProbeSeries m_series;
  double m_lastTime;
  std::size_t m_surfaces = 0;
};

}  // namespace pflow::backend
