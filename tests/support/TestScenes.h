// Small builders for run configurations used by the physics tests and the accuracy study (bench/accuracy).
#pragma once
#include <cmath>
#include <numbers>

#include "compute/sim/RunConfig.h"
#include "compute/sim/TimeStep.h"

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

}  // namespace pflow::test
