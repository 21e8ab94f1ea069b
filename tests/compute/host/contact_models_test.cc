// Unit tests of the contact sub-models: signs, symmetry, the Coulomb cap, history rotation, the
// restitution map, rolling resistance.
#include <gtest/gtest.h>

#include <cmath>

#include "compute/dem/contact/ContactModels.h"

namespace pflow::compute::contact {
namespace {

ContactParams params(double mu = 0.5, double e = 0.5, double muR = 0.0) {
  ContactParams p;
  p.effYoung = 5e9;
  p.effShear = 2e9;
  p.restitution = e;
  p.dampingCoeff = dampingCoeffForRestitution(e);
  p.tangentialRatio = std::sqrt(4 * p.effShear / p.effYoung);
  p.friction = mu;
  p.rollingFriction = muR;
  return p;
}

ContactState<double> state(Vec3d n, double overlap, Vec3d vRel, Vec3d wRel = {0, 0, 0}) {
  return {n, overlap, vRel, wRel, 5e-3, 1e-3, 1e-8, 1e-2};
}

TEST(NormalModel, HertzForceAndStiffness) {
  const double E = 1e9, R = 1e-2, d = 1e-5;
  EXPECT_DOUBLE_EQ(normal::hertzForce(E, R, d), 4.0 / 3.0 * E * std::sqrt(R) * std::pow(d, 1.5));
  // Stiffness is the derivative of the force.
  const double h = 1e-10;
  const double fd = (normal::hertzForce(E, R, d + h) - normal::hertzForce(E, R, d - h)) / (2 * h);
  EXPECT_NEAR(normal::hertzStiffness(E, R, d), fd, 1e-6 * fd);
  // Energy is the integral of the force.
  const double fe = (normal::hertzEnergy(E, R, d + h) - normal::hertzEnergy(E, R, d - h)) / (2 * h);
  EXPECT_NEAR(normal::hertzForce(E, R, d), fe, 1e-6 * fe);
}

TEST(NormalModel, KernelNormalForceIsTheReferenceHertzAndDashpot) {
  // hertzNormal (what the kernels call) against the sub-model helpers: elastic alone at rest and without damping;
  // the continuous dashpot's coefficient c sqrt(S_n m*) returned for the tangential part.
  const double R = 5e-3, d = 1e-5, m = 1e-3, dt = 1e-7, sqrtRd = std::sqrt(R * d);
  for (double e : {1.0, 0.5, 0.1}) {
    const ContactParams p = params(0.5, e);
    double dampN = -1, touch = -1;
    EXPECT_NEAR(normal::hertzNormal(p, d, sqrtRd, 0.0, m, dt, dampN, touch), normal::hertzForce(p.effYoung, R, d),
                1e-12 * normal::hertzForce(p.effYoung, R, d)) << e;
    EXPECT_NEAR(dampN, p.dampingCoeff * std::sqrt(normal::hertzStiffness(p.effYoung, R, d) * m), 1e-12 * (dampN + 1e-30)) << e;
  }
  // Approaching, a damped contact pushes harder than the elastic force alone; e = 1 does not.
  double dampN, touch;
  EXPECT_GT(normal::hertzNormal(params(0.5, 0.5), d, sqrtRd, 1.0, m, dt, dampN, touch), normal::hertzForce(5e9, R, d));
  EXPECT_DOUBLE_EQ(normal::hertzNormal(params(0.5, 1.0), d, sqrtRd, 1.0, m, dt, dampN, touch), normal::hertzForce(5e9, R, d));
}

TEST(HertzMindlin, NormalForceIsRepulsive) {
  const auto out = hertzMindlin(params(), state({1, 0, 0}, 1e-5, {0, 0, 0}), Vec3d{0, 0, 0}, 1e-7);
  EXPECT_LT(out.force.x, 0);  // pushes i away from j
  EXPECT_DOUBLE_EQ(out.force.y, 0);
  EXPECT_GT(out.normalForce, 0);
}

TEST(HertzMindlin, DampingOpposesApproachAndNeverAttracts) {
  const auto p = params(0.5, 0.3);
  const auto approach = hertzMindlin(p, state({1, 0, 0}, 1e-5, {1, 0, 0}), Vec3d{0, 0, 0}, 1e-7);
  const auto rest = hertzMindlin(p, state({1, 0, 0}, 1e-5, {0, 0, 0}), Vec3d{0, 0, 0}, 1e-7);
  EXPECT_LT(approach.force.x, rest.force.x);  // stronger repulsion while approaching
  // Separating fast at a tiny overlap: the dashpot would pull; the clip keeps F_n >= 0.
  const auto sep = hertzMindlin(p, state({1, 0, 0}, 1e-9, {-10, 0, 0}), Vec3d{0, 0, 0}, 1e-7);
  EXPECT_EQ(sep.normalForce, 0.0);
  EXPECT_LE(sep.force.x, 0.0);
}

TEST(HertzMindlin, PairForcesAreEqualAndOpposite) {
  const auto p = params(0.4, 0.6, 0.1);
  const Vec3d n{0.6, 0.8, 0}, v{0.3, -0.2, 0.5}, w{1, 2, 3};
  const auto fi = hertzMindlin(p, state(n, 2e-5, v, w), Vec3d{0, 0, 0}, 1e-7);
  const auto fj = hertzMindlin(p, state(-n, 2e-5, -v, -w), Vec3d{0, 0, 0}, 1e-7);
  EXPECT_NEAR(fi.force.x, -fj.force.x, 1e-12 * norm(fi.force));
  EXPECT_NEAR(fi.force.y, -fj.force.y, 1e-12 * norm(fi.force));
  EXPECT_NEAR(fi.force.z, -fj.force.z, 1e-12 * norm(fi.force));
  EXPECT_NEAR(fi.history.x, -fj.history.x, 1e-20);
}

TEST(HertzMindlin, TangentialForceOpposesSlipAndIsCappedByCoulomb) {
  const double mu = 0.3;
  const auto p = params(mu, 1.0);
  // Small slip: spring force below the cap, opposite to the displacement.
  const auto small = hertzMindlin(p, state({0, 0, 1}, 1e-5, {1e-3, 0, 0}), Vec3d{1e-9, 0, 0}, 1e-7);
  EXPECT_FALSE(small.sliding);
  EXPECT_LT(small.force.x, 0);
  // Large displacement: |F_t| = mu F_n exactly, and the spring alone carries it.
  const auto big = hertzMindlin(p, state({0, 0, 1}, 1e-5, {0, 0, 0}), Vec3d{1e-3, 2e-3, 0}, 1e-7);
  EXPECT_TRUE(big.sliding);
  const Vec3d ft{big.force.x, big.force.y, 0};
  EXPECT_NEAR(norm(ft), mu * big.normalForce, 1e-12 * big.normalForce);
  const double st = tangential::mindlinStiffness(p.effShear, 5e-3, 1e-5);
  EXPECT_NEAR(-st * big.history.x, ft.x, 1e-12 * norm(ft));
  EXPECT_NEAR(-st * big.history.y, ft.y, 1e-12 * norm(ft));
  // Direction kept: opposite to the stored displacement.
  EXPECT_NEAR(ft.y / ft.x, 2.0, 1e-12);
}

TEST(HertzMindlin, TorqueIsLeverArmCrossTangentialForce) {
  const auto p = params(0.5, 1.0);
  // i above j's contact (n = -z, contact point below i), sliding +x: friction -x, spin about +y.
  const auto out = hertzMindlin(p, state({0, 0, -1}, 1e-5, {0.01, 0, 0}), Vec3d{0, 0, 0}, 1e-6);
  EXPECT_LT(out.force.x, 0);
  EXPECT_GT(out.torque.y, 0);
  EXPECT_NEAR(out.torque.y, 1e-2 * -out.force.x, 1e-12);
}

TEST(TangentialHistory, RotationKeepsMagnitudeAndIsTangent) {
  const Vec3d xi{1e-6, 2e-6, 0.5e-6};
  const Vec3d n = (1.0 / std::sqrt(3.0)) * Vec3d{1, 1, 1};
  const Vec3d r = tangential::rotateHistory(xi, n);
  EXPECT_NEAR(norm(r), norm(xi), 1e-18);
  EXPECT_NEAR(dot(r, n), 0.0, 1e-18);
  // Already tangent: unchanged. Parallel to n: forgotten.
  const Vec3d t{1e-6, -1e-6, 0};
  EXPECT_EQ(tangential::rotateHistory(t, n).x, t.x);
  EXPECT_EQ(norm(tangential::rotateHistory(2e-6 * n, n)), 0.0);
}

TEST(RollingResistance, OpposesRelativeSpinAndIsLimited) {
  const Vec3d w{0, 5, 0};
  const Vec3d t = rolling::constantTorque(0.1, 2.0, 1e-2, w, 1e-3, 1e-6);
  EXPECT_NEAR(t.y, -0.1 * 2.0 * 1e-2, 1e-15);
  // Near rest the torque cannot reverse the spin within a step: |tau| <= I* |w| / dt.
  const Vec3d slow{0, 1e-9, 0};
  const Vec3d ts = rolling::constantTorque(0.1, 2.0, 1e-2, slow, 1e-8, 1e-6);
  EXPECT_NEAR(std::fabs(ts.y), 1e-8 * 1e-9 / 1e-6, 1e-20);
  EXPECT_EQ(norm(rolling::constantTorque(0.0, 2.0, 1e-2, w, 1e-3, 1e-6)), 0.0);
}

TEST(Restitution, MapIsExactAndMonotone) {
  double prev = 1e300;
  for (double e = 0.05; e < 1.0; e += 0.05) {
    const double c = dampingCoeffForRestitution(e);
    EXPECT_NEAR(restitutionForDampingCoeff(c), e, 1e-6);
    EXPECT_LT(c, prev);
    prev = c;
  }
  EXPECT_EQ(dampingCoeffForRestitution(1.0), 0.0);
}

TEST(StepDashpot, RestingContactGetsTheContinuousDashpot) {
  // vn dt << delta: the exact-impulse form is C delta^{1/4} vn at the step's mean overlap (to float's rounding of
  // the series' correction).
  const double C = 3.0, d = 1e-5, r0 = std::sqrt(std::sqrt(d));
  for (double vn : {1e-9, -1e-9, 1e-3, -1e-3}) {
    const double dt = 1e-8, mid = std::sqrt(std::sqrt(d - 0.5 * vn * dt));
    EXPECT_NEAR(normal::stepDashpot(C * r0, d, vn, dt), C * mid * vn, 1e-7 * std::fabs(C * mid * vn)) << vn;
  }
  EXPECT_EQ(normal::stepDashpot(C * r0, d, 0.0, 1e-8), 0.0);
}

TEST(StepDashpot, SeriesAndFourthRootsAgreeWhereTheyMeet) {
  // The series in eps = vn dt / delta is used up to |eps| = 0.25; just past it the fourth roots take over.
  const double C = 2.0, d = 1e-6, r0 = std::sqrt(std::sqrt(d)), dt = 1e-6;
  for (double sign : {1.0, -1.0}) {
    const double below = normal::stepDashpot(C * r0, d, sign * 0.2499999 * d / dt, dt);
    const double above = normal::stepDashpot(C * r0, d, sign * 0.2500001 * d / dt, dt);
    EXPECT_NEAR(below / above, 0.2499999 / 0.2500001, 4e-7) << sign;
  }
}

TEST(StepDashpot, ImpulseOverTheStepFromTheFirstTouch) {
  // A contact that began within the step: the impulse over [touch, t] is (4/5) C delta^{5/4}; it vanishes as the
  // overlap does, so the force is continuous at the first touch.
  const double C = 2.0, vn = 1.0, dt = 1e-6;
  for (double d : {0.3e-6, 1e-9, 1e-15}) {
    const double f = normal::stepDashpot(C * std::sqrt(std::sqrt(d)), d, vn, dt);
    EXPECT_NEAR(f * dt, 0.8 * C * std::pow(d, 1.25), 1e-12 * f * dt) << d;
  }
  // Deeper: the impulse over [t - dt, t]; separating, the same with the sign of the motion.
  const double d = 2.7e-6, r = std::sqrt(std::sqrt(d));
  const double g = normal::stepDashpot(C * r, d, vn, dt);
  EXPECT_NEAR(g * dt, 0.8 * C * (std::pow(d, 1.25) - std::pow(d - vn * dt, 1.25)), 1e-12 * g * dt);
  const double u = normal::stepDashpot(C * r, d, -vn, dt);
  EXPECT_NEAR(u * dt, 0.8 * C * (std::pow(d, 1.25) - std::pow(d + vn * dt, 1.25)), 1e-12 * std::fabs(u * dt));
}

TEST(StepDashpot, ShareAndTouchForTheTangentialDashpot) {
  // The force is C delta^{1/4} vn times the share; on a contact's first step the part in contact is delta / (vn dt)
  // and the share 4/5 of it (ContactModels.h, hertzMindlin); touch is 1 on every other step.
  const double C = 2.0, dt = 1e-6;
  for (double d : {2.7e-6, 1e-6, 0.3e-6}) {
    for (double vn : {0.01, 0.2, 1.0, -0.2, -1.0}) {
      double share = -1, touch = -1;
      const double r = std::sqrt(std::sqrt(d));
      const double f = normal::stepDashpot(C * r, d, vn, dt, share, touch);
      EXPECT_NEAR(f, C * r * vn * share, 1e-12 * std::fabs(f)) << d << " " << vn;
      if (vn * dt >= d) {  // a first step
        EXPECT_NEAR(touch, d / (vn * dt), 1e-15) << d << " " << vn;
        EXPECT_NEAR(share, 0.8 * d / (vn * dt), 1e-15) << d << " " << vn;
      } else {
        EXPECT_EQ(touch, 1.0) << d << " " << vn;
      }
    }
  }
}

TEST(StepDashpot, ShareContinuousAcrossTheBranches) {
  const double C = 2.0, d = 1e-6, r0 = std::sqrt(std::sqrt(d)), dt = 1e-6;
  for (double sign : {1.0, -1.0}) {
    double below = 0, above = 0, t = 0;
    normal::stepDashpot(C * r0, d, sign * 0.2499999 * d / dt, dt, below, t);
    normal::stepDashpot(C * r0, d, sign * 0.2500001 * d / dt, dt, above, t);
    EXPECT_NEAR(below, above, 4e-7) << sign;
  }
}

TEST(StepDashpot, DiscreteStepRestitutesTheRequestedValue) {
  // pflow's step on the dimensionless impact: within 1 % for every e from 0.1 to 1 when the contact lasts at
  // least 12 steps (h <= 0.268), wherever in its first step the contact begins; to 3e-4 at 1600 steps.
  for (double e : {0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0}) {
    double poly[3];
    calibrateDashpotForStep(e, poly);
    const double c = dampingCoeffForRestitution(e);
    for (double h : {0.005, 0.05, 0.1, 0.16, 0.2, 0.25, 0.268})
      for (int k = 0; k < 16; ++k) {
        const double phase = (k + 0.5) / 16;
        EXPECT_NEAR(restitutionOfStep(c, poly, h, phase), e, 0.01 * e) << "e " << e << " h " << h << " phase " << phase;
      }
    EXPECT_NEAR(restitutionOfStep(c, poly, 0.002, 0.5), e, 3e-4 * e);
  }
  // Without the step correction, e = 0.1 at 32 steps per contact comes out about 3 % high: it is needed.
  const double none[3] = {0, 0, 0};
  EXPECT_GT(restitutionOfStep(dampingCoeffForRestitution(0.1), none, 0.1, 0.5), 1.02 * 0.1);
}

TEST(Restitution, LinearSpringMappingIsWrongForHertz) {
  // The mapping valid for linear springs restitutes far more than asked for with Hertz at low e.
  EXPECT_GT(restitutionForDampingCoeff(linearSpringDampingCoeff(0.1)), 0.2);
  EXPECT_GT(restitutionForDampingCoeff(linearSpringDampingCoeff(0.5)), 0.55);
}

}  // namespace
}  // namespace pflow::compute::contact
