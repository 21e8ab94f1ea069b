// The realised coefficient of restitution at pflow's default time step (0.2 of the Rayleigh time, simulation.dt
// unset), over the grid issue 21 names: e from 0.1 to 1, relative impact speeds from 0.01 to 10 m/s,
// sphere-wall, equal spheres, a 1:4 radius pair and two materials, each contact beginning at its own place
// within a step. The claim (docs/accuracy.md, "Restitution at the working time step"): within 1 % wherever the
// step resolves the contact with at least 12 steps (h <= 0.268 in units of its Hertz time scale; pflow warns below
// 20 for the fastest initial particle). Cases the default step resolves more coarsely (a soft material hit at
// metres per second) are printed with their error, not held to 1 %.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "compute/dem/Simulation.h"
#include "compute/dem/TimeStep.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::MaterialConfig;
using compute::Precision;
using compute::RunConfig;
using compute::Simulation;

enum class Kind { kWall, kEqual, kOneToFour, kTwoMaterials };
const char* kindName(Kind k) {
  switch (k) {
    case Kind::kWall: return "sphere-wall";
    case Kind::kEqual: return "equal spheres";
    case Kind::kOneToFour: return "radii 1:4";
    case Kind::kTwoMaterials: return "glass-steel";
  }
  return "";
}

struct Mat {
  const char* name;
  double E, nu, rho, R;  // R: the (smaller) sphere's radius [m]
};
const Mat kGlass{"glass", 6.3e10, 0.24, 2500, 1e-3};
const Mat kSteel{"steel", 2.0e11, 0.30, 7800, 1e-3};
const Mat kSoft{"soft", 1e7, 0.30, 2500, 0.5e-3};  // the re-measurement: 1 mm spheres, E = 1e7 Pa

MaterialConfig toConfig(const Mat& m, double e) { return material(m.name, m.E, m.nu, m.rho, e); }
double reducedModulus(const Mat& a, const Mat& b) {
  return 1.0 / ((1 - a.nu * a.nu) / a.E + (1 - b.nu * b.nu) / b.E);
}

struct Outcome {
  double realised = 0, h = 0;
  std::string failure;  // the step's error, if a step failed
};

// One impact at relative normal speed v; `phase` in (0, 1) places the first touch within a step.
Outcome impact(Kind kind, const Mat& m, double e, double v, double phase, Precision prec) {
  RunConfig c;
  c.sim.gravity = {0, 0, 0};
  c.sim.precision = prec;
  const double R = m.R;
  double effRadius = 0, effMass = 0, effYoung = 0;
  const double m1 = sphereMass(R, m.rho);
  if (kind == Kind::kWall) {
    c.materials = {toConfig(m, e), rigid(e)};
    c.pairs.push_back({0, 1, e, std::nullopt, std::nullopt});
    addParticle(c, {0, 0, 0}, R, 0, {0, 0, -v});
    c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 1, "floor"));
    effRadius = R, effMass = m1, effYoung = m.E / (1 - m.nu * m.nu);
  } else {
    const Mat& other = kind == Kind::kTwoMaterials ? kSteel : m;
    const double R2 = kind == Kind::kOneToFour ? 4 * R : R;
    const double m2 = sphereMass(R2, other.rho);
    c.materials = {toConfig(m, e)};
    if (kind == Kind::kTwoMaterials) {
      c.materials.push_back(toConfig(other, e));
      c.pairs.push_back({0, 1, e, std::nullopt, std::nullopt});
    }
    // Equal and opposite momenta: the centre of mass rests.
    addParticle(c, {0, 0, 0}, R, 0, {v * m2 / (m1 + m2), 0, 0});
    addParticle(c, {0, 0, 0}, R2, kind == Kind::kTwoMaterials ? 1 : 0, {-v * m1 / (m1 + m2), 0, 0});
    effRadius = R * R2 / (R + R2), effMass = m1 * m2 / (m1 + m2), effYoung = reducedModulus(m, other);
  }
  c.sim.duration = 1;
  const auto ts = compute::chooseTimeStep(c);
  EXPECT_TRUE(ts.isOk());
  const double dt = ts.value().dt;
  // The first touch falls `phase` of a step before the end of the first step.
  const double gap = (1 - phase) * v * dt;
  if (kind == Kind::kWall) {
    c.particles.position[0] = {0, 0, R + gap};
  } else {
    c.particles.position[0] = {-R - gap / 2, 0, 0};
    c.particles.position[1] = {c.particles.radius[1] + gap / 2, 0, 0};
  }
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  Outcome out;
  const double k = 4.0 / 3.0 * effYoung * std::sqrt(effRadius);
  out.h = dt / (std::pow(effMass / k, 0.4) * std::pow(v, -0.2));
  bool touched = false;
  for (int n = 0; n < 1'000'000; ++n) {
    const Status st = sim.value()->step();
    if (!st.isOk()) {
      out.failure = st.toString();
      return out;
    }
    const auto s = sim.value()->snapshot();
    const Vec3d* x = s.find("position")->as<Vec3d>();
    const double* rad = s.find("radius")->as<double>();
    const double overlap = kind == Kind::kWall ? rad[0] - x[0].z : rad[0] + rad[1] - norm(x[1] - x[0]);
    touched |= overlap > 0;
    if (touched && overlap <= 0) {
      const Vec3d* u = s.find("velocity")->as<Vec3d>();
      out.realised = kind == Kind::kWall ? u[0].z / v : (u[1].x - u[0].x) / v;
      return out;
    }
  }
  ADD_FAILURE() << "the contact never ended";
  return out;
}

TEST(RestitutionAtDefaultStep, WithinOnePercentWhereverTheStepResolvesTheContact) {
  const double es[] = {0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0};
  const double speeds[] = {0.01, 0.1, 1.0, 10.0};
  int held = 0, coarse = 0, refused = 0, n = 0;
  double worstHeld = 0;
  for (Kind kind : {Kind::kWall, Kind::kEqual, Kind::kOneToFour, Kind::kTwoMaterials})
    for (const Mat* m : {&kGlass, &kSoft}) {
      if (kind == Kind::kTwoMaterials && m != &kGlass) continue;
      for (double v : speeds)
        for (double e : es) {
          const double phase = 0.05 + 0.9 * ((n++ * 7) % 11) / 10.0;  // spread over the step
          const Outcome o = impact(kind, *m, e, v, phase, Precision::kDouble);
          if (!o.failure.empty()) {
            // Only where Hertz itself no longer holds: pflow stops a run whose overlap passes its limit.
            std::printf("refused: %s, %s, v %g m/s, e %g: %s\n", kindName(kind), m->name, v, e, o.failure.c_str());
            EXPECT_NE(o.failure.find("overlap"), std::string::npos) << o.failure;
            ++refused;
            continue;
          }
          const double err = o.realised / e - 1;
          if (o.h <= 0.268) {
            ++held;
            worstHeld = std::max(worstHeld, std::fabs(err));
            EXPECT_NEAR(o.realised, e, 0.01 * e)
                << kindName(kind) << ", " << m->name << ", v " << v << " m/s, e " << e << ", h " << o.h;
          } else {
            ++coarse;
            std::printf("coarse: %s, %s, v %g m/s, e %g: h %.3f (%.1f steps per contact), error %+.2f %%\n",
                        kindName(kind), m->name, v, e, o.h, 3.218 / o.h, 100 * err);
          }
        }
    }
  std::printf("%d impacts within the claim (worst %.3f %%), %d coarser, %d refused\n", held, 100 * worstHeld, coarse,
              refused);
  EXPECT_EQ(held, 161);  // every glass and glass-steel case; the soft material up to 0.1 m/s, and at 1 m/s in the 1:4 pair
  EXPECT_LE(refused, 3);
}

TEST(RestitutionAtDefaultStep, FloatRealisesWhatDoubleDoes) {
  for (double e : {0.1, 0.5, 0.9})
    for (double v : {0.01, 1.0}) {
      const Outcome d = impact(Kind::kEqual, kGlass, e, v, 0.4, Precision::kDouble);
      const Outcome f = impact(Kind::kEqual, kGlass, e, v, 0.4, Precision::kFloat);
      EXPECT_NEAR(f.realised, d.realised, 2e-3 * e) << "e " << e << " v " << v;
    }
}

}  // namespace
}  // namespace pflow::test
