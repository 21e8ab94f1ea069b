// Oblique impacts across the micro-slip regime (Chung & Ooi 2011, test 4: an alumina sphere, R = 2.5 mm, E = 380 GPa,
// nu = 0.23, rho = 4000, mu = 0.092, e = 0.98, at 3.9 m/s from 2 to 80 degrees off the normal), where at small
// incidence the tangential spring, not friction, decides the rebound. Three ways of computing the same impact must
// agree at pflow's default step (0.2 Rayleigh times):
//   - the sphere on a rigid plane (the wall kernel),
//   - two identical spheres in a symmetric collision (the pair kernel; the same dimensionless problem: Hertz-Mindlin
//     outcomes depend on the incidence, mu, e and the ratio of tangential to normal stiffness 2(1-nu)/(2-nu), which
//     are the same for an elastic pair and for a sphere on a rigid wall),
//   - an independent integration of the same contact law (Hertz, the dashpot for e, Mindlin's spring 8 G* a with its
//     dashpot and Coulomb cap, lever arm R - delta/2) for the sphere on the plane, at a step 1/50 of pflow's,
// and at large incidence (gross sliding throughout) the rigid-body closed form: omega' R / V = (5/2) mu (1 + e)
// cos(theta). Measured: the contact point's tangential velocity ratio u'/u and the spin omega' R / V. The published
// curves of Chung & Ooi and the Maw-Barber-Fawcett analysis are not in this repository; docs/accuracy.md says so.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

constexpr double kE = 380e9, kNu = 0.23, kRho = 4000, kR = 2.5e-3, kMu = 0.092, kRest = 0.98, kV = 3.9;
constexpr double kDeg = std::numbers::pi / 180;

struct Rebound {
  double tangentialRatio = 0;  // u' / u: the contact point's tangential velocity after over before
  double spin = 0;             // omega' R / V (V: the sphere's speed relative to what it hits)
};

// pflow: the sphere on a rigid plane (wall) or two identical spheres (pair), the relative velocity V at theta from the
// normal; run well past the contact.
Rebound pflowImpact(bool pair, double theta, double dtScale = 1) {
  const double gap = 1e-7;
  RunConfig c;
  c.materials = {material("alumina", kE, kNu, kRho, kRest, kMu), rigid(kRest, kMu)};
  compute::MaterialPairConfig wall;
  wall.a = 0, wall.b = 1, wall.restitution = kRest, wall.friction = kMu;
  c.pairs = {wall};
  const double vt = kV * std::sin(theta), vn = kV * std::cos(theta);
  if (pair) {
    addParticle(c, {0, 0, -kR - gap / 2}, kR, 0, {0.5 * vt, 0, 0.5 * vn});
    addParticle(c, {0, 0, kR + gap / 2}, kR, 0, {-0.5 * vt, 0, -0.5 * vn});
  } else {
    c.planes = {plane({0, 0, 0}, {0, 0, 1}, 1, "floor")};
    addParticle(c, {0, 0, kR + gap}, kR, 0, {vt, 0, -vn});
  }
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1;
  if (dtScale != 1) c.sim.dt = dtScale * 0.2 * compute::rayleighTime(kR, kRho, kE, kNu);
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  if (!sim.isOk()) return {};
  const double tc = hertzImpact(kE / (1 - kNu * kNu), kR, sphereMass(kR, kRho), kV).contactTime;
  EXPECT_TRUE(sim.value()->runUntil(3 * tc + gap / vn).isOk());
  const auto snap = sim.value()->snapshot({"velocity", "angular_velocity", "id"});
  const Vec3d* v = snap.find("velocity")->as<Vec3d>();
  const Vec3d* w = snap.find("angular_velocity")->as<Vec3d>();
  const Gid* id = snap.find("id")->as<Gid>();
  const std::size_t lower = pair && id[0] != 0 ? 1 : 0;  // the sphere that moved +x (pair) or the sphere (wall)
  Rebound r;
  if (pair) {
    // The lower sphere's contact point is at +R z: u = v_x + (w x R z)_x = v_x + R w_y; relative to the upper one's
    // (by symmetry its negative): 2 u. The incoming relative tangential velocity is vt.
    r.tangentialRatio = 2 * (v[lower].x + kR * w[lower].y) / vt;
    r.spin = -w[lower].y * kR / (0.5 * kV);
  } else {
    // The contact point at -R z: u = v_x - R w_y.
    r.tangentialRatio = (v[0].x - kR * w[0].y) / vt;
    r.spin = w[0].y * kR / kV;
  }
  return r;
}

// The same contact law for the sphere on the plane, integrated independently (velocity Verlet, 1/50 of pflow's step).
Rebound referenceImpact(double theta, double divide = 50) {
  const double Es = kE / (1 - kNu * kNu), G = kE / (2 * (1 + kNu)), Gs = G / (2 - kNu);
  const double m = sphereMass(kR, kRho), I = 0.4 * m * kR * kR;
  const double c = compute::dampingCoeffForRestitution(kRest), ratio = std::sqrt(4 * Gs / Es);
  const double dt = 0.2 * compute::rayleighTime(kR, kRho, kE, kNu) / divide;
  double z = kR, vz = -kV * std::cos(theta), vx = kV * std::sin(theta), wy = 0, xi = 0;
  auto forces = [&](double zz, double vzz, double vxx, double wyy, double& fz, double& fx, double& ty, double& xiNew, double h) {
    fz = fx = ty = 0;
    const double d = kR - zz;
    if (d <= 0) {
      xiNew = 0;
      return;
    }
    const double a = std::sqrt(kR * d), vn = -vzz;  // approaching > 0
    const double damp = c * std::sqrt(2 * Es * a * m);
    double fn = 4.0 / 3.0 * Es * a * d + damp * vn;
    if (fn < 0) fn = 0;
    const double l = kR - 0.5 * d;
    const double u = vxx - l * wyy;
    double x = xi + h * u;
    const double kt = 8 * Gs * a;
    double ft = -kt * x - damp * ratio * u;
    if (std::fabs(ft) > kMu * fn) {
      ft = ft > 0 ? kMu * fn : -kMu * fn;
      x = -ft / kt;
    }
    xiNew = x;
    fz = fn, fx = ft, ty = -l * ft;  // torque about y of F_t at -l z: (r x F)_y = z F_x - x F_z = -l F_t
  };
  double fz, fx, ty, xiNew;
  forces(z, vz, vx, wy, fz, fx, ty, xiNew, 0.0);
  bool touched = false;
  for (long k = 0; k < 100000000; ++k) {
    vz += 0.5 * dt * fz / m, vx += 0.5 * dt * fx / m, wy += 0.5 * dt * ty / I;
    z += dt * vz;
    forces(z, vz, vx, wy, fz, fx, ty, xiNew, dt);
    xi = xiNew;
    vz += 0.5 * dt * fz / m, vx += 0.5 * dt * fx / m, wy += 0.5 * dt * ty / I;
    if (z < kR) touched = true;
    if (touched && z > kR) break;
  }
  return {(vx - kR * wy) / (kV * std::sin(theta)), wy * kR / kV};
}

TEST(MicroSlip, ChungOoiTest4WallPairAndIndependentIntegrationAgree) {
  std::printf("theta  u'/u: wall    pair    reference | spin w'R/V: wall    pair    reference  gross-sliding\n");
  for (double deg : {2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 80.0}) {
    const double th = deg * kDeg;
    const Rebound w = pflowImpact(false, th), p = pflowImpact(true, th), r = referenceImpact(th);
    const double sliding = 2.5 * kMu * (1 + kRest) * std::cos(th);
    std::printf("%5.1f  %+9.4f %+9.4f %+9.4f | %9.5f %9.5f %9.5f  %9.5f\n", deg, w.tangentialRatio, p.tangentialRatio,
                r.tangentialRatio, w.spin, p.spin, r.spin, sliding);
    // The spin to 1 % of the gross-sliding value (its largest); the tangential ratio (from about -0.4 to 1) to 0.01
    // between the two kernels everywhere, and against the converged model to 0.005 from 15 degrees and 0.035 below.
    // Below 15 degrees the rebound depends on where in a step the contact began (at 2 degrees u'/u runs from 0.97 to
    // 1.02 over that phase, against 0.949 converged): the step that begins a contact adds a whole step of tangential
    // displacement. Counting it from the first touch removes most of it (0.95-0.97) but cost 14 % of the double force
    // kernel on an H100 (an fp64 division) and was left out; docs/accuracy.md, "Micro-slip".
    const double spinScale = 0.01 * 2.5 * kMu * (1 + kRest);
    EXPECT_NEAR(w.spin, r.spin, spinScale) << deg << " deg: wall vs reference";
    EXPECT_NEAR(p.spin, w.spin, spinScale) << deg << " deg: pair vs wall";
    EXPECT_NEAR(w.tangentialRatio, r.tangentialRatio, deg < 15 ? 0.035 : 0.005) << deg << " deg: wall vs reference";
    EXPECT_NEAR(p.tangentialRatio, w.tangentialRatio, 0.01) << deg << " deg: pair vs wall";
    if (std::tan(th) > 3.5 * kMu * (1 + kRest) * 1.2) EXPECT_NEAR(w.spin, sliding, 0.01 * sliding) << deg << " deg: gross sliding";
  }
}

}  // namespace
}  // namespace pflow::test
