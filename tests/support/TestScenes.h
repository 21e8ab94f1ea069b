// Small builders for run configurations used by the physics tests and the accuracy study (bench/accuracy).
#pragma once
#include <cmath>
#include <cstdint>
#include <numbers>

#include "compute/sim/RunConfig.h"
#include "compute/dem/TimeStep.h"

namespace pflow::test {

inline compute::MaterialConfig material(const std::string& name, double E, double nu, double rho, double e = 1.0,
                                        double mu = 0.0, double muRoll = 0.0) {
  compute::MaterialConfig m;
  m.name = name;
  m.youngsModulus = E;
  m.poissonRatio = nu;
  m.density = rho;
  m.restitution = e;
  m.friction = mu;
  m.rollingFriction = muRoll;
  return m;
}

// A practically rigid wall material: E* and G* reduce to the particle's own terms.
inline compute::MaterialConfig rigid(double e = 1.0, double mu = 0.0, double muRoll = 0.0) {
  return material("rigid", 1e30, 0.3, 1e4, e, mu, muRoll);
}

inline void addParticle(compute::RunConfig& c, Vec3d x, double r, int mat, Vec3d v = {0, 0, 0}, Vec3d w = {0, 0, 0}) {
  c.particles.position.push_back(x);
  c.particles.radius.push_back(r);
  c.particles.material.push_back(mat);
  c.particles.velocity.push_back(v);
  c.particles.angularVelocity.push_back(w);
}

inline compute::PlaneConfig plane(Vec3d point, Vec3d normal, int mat, const std::string& name = "plane") {
  compute::PlaneConfig p;
  p.name = name;
  p.point = point;
  p.normal = normal;
  p.material = mat;
  return p;
}

inline double sphereMass(double r, double rho) { return rho * 4.0 / 3.0 * std::numbers::pi * r * r * r; }

// Hertz closed forms for a normal impact at relative speed v.
struct HertzImpact {
  double maxOverlap, maxForce, contactTime;
};
inline HertzImpact hertzImpact(double effYoung, double effRadius, double effMass, double v) {
  const double dmax = std::pow(15.0 * effMass * v * v / (16.0 * effYoung * std::sqrt(effRadius)), 0.4);
  const double fmax = 4.0 / 3.0 * effYoung * std::sqrt(effRadius) * std::pow(dmax, 1.5);
  return {dmax, fmax, compute::hertzContactTime(effRadius, effMass, effYoung, v)};
}

// A 4x4x4 block of glass spheres, each pair overlapping by 0.5 % of the diameter, in an open box of planes:
// elastic (e = 1), so nothing damps an integration that gains energy.
inline compute::RunConfig compressedBlock(double dtInRayleighTimes, double restitution = 1.0) {
  compute::RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, restitution, 0.3)};
  const double r = 0.01, a = 2 * r * 0.995;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) addParticle(c, {r + i * a, r + j * a, r + k * a}, r, 0);
  const double side = r + 3 * a + r;
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor"), plane({0, 0, 0}, {1, 0, 0}, 0, "x0"),
              plane({side, 0, 0}, {-1, 0, 0}, 0, "x1"), plane({0, 0, 0}, {0, 1, 0}, 0, "y0"),
              plane({0, side, 0}, {0, -1, 0}, 0, "y1")};
  c.sim.dt = dtInRayleighTimes * compute::rayleighTime(r, 2800, 4.8e10, 0.2);
  c.sim.duration = 2000 * *c.sim.dt;
  return c;
}

// A frictional, rolling-resistant heap of 600 spheres of radius about r poured into a box: contacts start, slide,
// end and change owner at rebuilds (particles cross cells).
inline compute::RunConfig pouredHeap(double r, int threads = 0) {
  compute::RunConfig c;
  c.materials = {material("m", 1e7, 0.3, 2500, 0.5, 0.5)};
  c.materials[0].rollingFriction = 0.05;
  const double gap = 2.1 * r;
  std::uint64_t seed = 7;
  auto jitter = [&] {
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    return (double(seed >> 11) / 9007199254740992.0 - 0.5) * 0.2 * r;
  };
  for (int k = 0; k < 600; ++k) {
    const int x = k % 10, y = (k / 10) % 10, z = k / 100;
    addParticle(c, {(x + 0.5) * gap + jitter(), (y + 0.5) * gap + jitter(), r + z * gap + jitter()}, r * (0.8 + 0.04 * (k % 6)), 0);
  }
  const double side = 10 * gap;
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor"), plane({0, 0, 0}, {1, 0, 0}, 0, "x0"),
              plane({side, 0, 0}, {-1, 0, 0}, 0, "x1"), plane({0, 0, 0}, {0, 1, 0}, 0, "y0"),
              plane({0, side, 0}, {0, -1, 0}, 0, "y1")};
  c.sim.gravity = {0, 0, -9.81};
  c.sim.duration = 1;
  c.sim.threads = threads;
  return c;
}

}  // namespace pflow::test
