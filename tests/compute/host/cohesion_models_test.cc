// Unit tests of the adhesion sub-models (contact::cohesion): the JKR contact radius solves its equation on the stable
// branch, the force has JKR's landmarks (-4/3, -3/2 and -5/6 pi dgamma R* at zero overlap, at the most tensile point
// and at the break), tends to Hertz when compressed, and derives from its potential; the constant model pulls with
// DMT's 2 pi dgamma R*; the Coulomb cap and rolling resistance scale with the load plus twice the pull-off force.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "compute/dem/contact/ContactModels.h"

namespace pflow::compute::contact {
namespace {

constexpr double kPi = std::numbers::pi;

ContactParams adhesive(int model, double dgamma, double e = 1.0, double mu = 0.0) {
  ContactParams p;
  p.effYoung = 5.5e6;
  p.effShear = 2.1e6;
  p.restitution = e;
  p.dampingCoeff = dampingCoeffForRestitution(e);
  p.tangentialRatio = std::sqrt(4 * p.effShear / p.effYoung);
  p.friction = mu;
  setCohesion(p, model, dgamma);
  return p;
}

// The normal force at overlap delta, nothing moving.
double force(const ContactParams& p, double R, double delta) {
  return normalPart<true>(p, delta, R, 0.0, 1e-5, 1e-6).force;
}

TEST(Jkr, ContactRadiusSolvesItsEquationOnTheStableBranch) {
  const ContactParams p = adhesive(cohesion::kJkr, 0.5);
  const double R = 5e-4, B = p.jkrB;
  const double dc = cohesion::jkrBreakOverlap(p.jkrBreak, R);
  EXPECT_NEAR(dc, -0.75 * std::cbrt(kPi * kPi * 0.25 * R / (p.effYoung * p.effYoung)), 1e-12 * std::fabs(dc));
  for (double f : {1.0, 0.999, 0.9, 0.5, 0.0, -1.0, -10.0, -1e3, -1e5}) {
    const double delta = f * dc;
    const double s = cohesion::jkrRootRadius(B, R, delta);
    const double a = s * s;
    EXPECT_NEAR(a * a / R - B * s, delta, 1e-9 * std::fabs(dc) + 1e-12 * std::fabs(delta)) << "delta " << delta;
    EXPECT_GE(s * s * s, 0.25 * B * R * (1 - 1e-6)) << "the stable branch, a >= a_c";
  }
  // At zero overlap, a0 = (2 pi dgamma R^2 / E*)^{1/3}.
  const double s0 = cohesion::jkrRootRadius(B, R, 0.0);
  EXPECT_NEAR(s0 * s0, std::cbrt(2 * kPi * 0.5 * R * R / p.effYoung), 1e-10 * s0 * s0);
  // Float solves it to float's precision.
  const float sf = cohesion::jkrRootRadius(float(B), float(R), float(0.3 * dc));
  EXPECT_NEAR(sf, cohesion::jkrRootRadius(B, R, 0.3 * dc), 2e-6 * sf);
}

// Fine powders: 10 um particles (R* = 2.5 um), E* = 5.5e8 Pa, dgamma = 0.1 J/m^2. The float path (float runs) solves
// the contact radius and force as the double one does, to float's precision, over the whole branch.
TEST(Jkr, FloatHoldsForFinePowders) {
  ContactParams p;
  p.effYoung = 5.5e8;
  setCohesion(p, cohesion::kJkr, 0.1);
  const double R = 2.5e-6, dc = cohesion::jkrBreakOverlap(p.jkrBreak, R);
  const double fc = 1.5 * kPi * 0.1 * R;
  for (double f : {0.999, 0.9, 0.5, 0.0, -1.0, -10.0, -100.0}) {
    const double delta = f * dc;
    const double s = cohesion::jkrRootRadius(p.jkrB, R, delta);
    const float sf = cohesion::jkrRootRadius(float(p.jkrB), float(R), float(delta));
    EXPECT_NEAR(sf, s, 1e-5 * s) << "delta " << delta;
    const double F = cohesion::jkrForce(p.effYoung, p.jkrB, R, s);
    const float Ff = cohesion::jkrForce(float(p.effYoung), float(p.jkrB), float(R), sf);
    EXPECT_NEAR(Ff, F, 1e-4 * std::max(fc, std::fabs(F))) << "delta " << delta;
  }
}

TEST(Jkr, ForceHasTheLandmarksOfTheTheory) {
  const double dgamma = 0.5, R = 5e-4;
  const ContactParams p = adhesive(cohesion::kJkr, dgamma);
  const double fc = 1.5 * kPi * dgamma * R;  // the pull-off force
  const double dc = cohesion::jkrBreakOverlap(p.jkrBreak, R);
  EXPECT_NEAR(force(p, R, 0.0), -4.0 / 3.0 * kPi * dgamma * R, 1e-9 * fc);
  EXPECT_NEAR(force(p, R, dc), -5.0 / 6.0 * kPi * dgamma * R, 1e-5 * fc);  // a double root: the solver's tolerance
  // Displacement control: the most tensile force along the branch is the pull-off force.
  double most = 0;
  for (int k = 0; k <= 20000; ++k) most = std::min(most, force(p, R, dc + (0.0 - dc) * k / 20000.0));
  EXPECT_NEAR(most, -fc, 1e-6 * fc);
  // Compressed far beyond the adhesive scale it is Hertz.
  const double deep = 1e4 * -dc;
  EXPECT_NEAR(force(p, R, deep) / normal::hertzForce(p.effYoung, R, deep), 1.0, 0.02);
  // The force derives from the potential: dPhi/d delta = F (central differences).
  for (double f : {0.9, 0.5, -0.5, -3.0}) {
    const double d = f * dc, h = 1e-4 * -dc;
    const double sp = cohesion::jkrRootRadius(p.jkrB, R, d + h), sm = cohesion::jkrRootRadius(p.jkrB, R, d - h);
    const double dphi = (cohesion::jkrEnergy(p.effYoung, p.jkrB, R, sp) - cohesion::jkrEnergy(p.effYoung, p.jkrB, R, sm)) / (2 * h);
    EXPECT_NEAR(dphi, force(p, R, d), 1e-5 * fc) << "delta " << d;
  }
  // Breaking dissipates Phi(delta_c) > 0; the well is deeper than that is high.
  const double w = cohesion::jkrEnergy(p.effYoung, p.jkrB, R, cohesion::jkrRootRadius(p.jkrB, R, dc));
  EXPECT_GT(w, 0.0);
  EXPECT_GT(adhesionWellDepth(p, R), 0.0);
  // The well's bottom is where the force is 0 (s^3 = 3/2 B R*, delta = B s / 2): contactEnergy there (solving a from
  // delta) is minus the well depth (from s directly), and it is the minimum of the potential.
  const double s0 = std::cbrt(1.5 * p.jkrB * R), d0 = 0.5 * p.jkrB * s0;
  EXPECT_NEAR(contactEnergy(p, R, d0), -adhesionWellDepth(p, R), 1e-6 * adhesionWellDepth(p, R));
  EXPECT_GT(contactEnergy(p, R, 0.9 * d0), contactEnergy(p, R, d0));
  EXPECT_GT(contactEnergy(p, R, 1.1 * d0), contactEnergy(p, R, d0));
}

TEST(Jkr, DashpotActsOnlyInCompressionAndNeverPullsBeyondHertz) {
  const double R = 5e-4;
  const ContactParams p = adhesive(cohesion::kJkr, 0.5, 0.3);
  const double dc = cohesion::jkrBreakOverlap(p.jkrBreak, R);
  const double still = normalPart<true>(p, 0.5 * dc, R, 0.0, 1e-5, 1e-6).force;
  EXPECT_EQ(normalPart<true>(p, 0.5 * dc, R, -0.1, 1e-5, 1e-6).force, still) << "no dashpot at negative overlap";
  const double d = 2.0 * -dc;
  const double elastic = normalPart<true>(p, d, R, 0.0, 1e-5, 1e-6).force;
  EXPECT_GT(normalPart<true>(p, d, R, 0.05, 1e-5, 1e-6).force, elastic) << "approaching: the dashpot pushes";
  const double pulling = normalPart<true>(p, d, R, -100.0, 1e-5, 1e-6).force;
  EXPECT_LT(pulling, elastic) << "receding: the dashpot pulls";
  EXPECT_GE(pulling, elastic - normal::hertzForce(p.effYoung, R, d) - 1e-12) << "but never beyond the Hertz part";
}

TEST(ConstantAdhesion, PullsWithDmtsForceWhileInContact) {
  const double dgamma = 0.5, R = 5e-4;
  const ContactParams p = adhesive(cohesion::kConstant, dgamma);
  const double f0 = 2 * kPi * dgamma * R;
  for (double d : {1e-9, 1e-7, 1e-5})
    EXPECT_NEAR(force(p, R, d), normal::hertzForce(p.effYoung, R, d) - f0, 1e-9 * f0) << d;
  EXPECT_NEAR(adhesionWellDepth(p, R), [&] {  // the most kinetic energy the contact releases: min of Phi
    double most = 0;
    for (int k = 1; k <= 100000; ++k) most = std::min(most, contactEnergy(p, R, 1e-10 * k));
    return -most;
  }(), 1e-4 * adhesionWellDepth(p, R));
}

TEST(Adhesion, CoulombCapAndRollingScaleWithTheLoadPlusTwiceThePullOff) {
  const double dgamma = 0.5, R = 5e-4, mu = 0.4;
  const ContactParams p = adhesive(cohesion::kJkr, dgamma, 1.0, mu);
  const double fc = 1.5 * kPi * dgamma * R;
  const double d = 1e-7;
  const NormalPart<double> np = normalPart<true>(p, d, R, 0.0, 1e-5, 1e-6);
  EXPECT_NEAR(np.load, np.force + 2 * fc, 1e-12 * fc);
  // A large tangential slip slides at mu (F + 2 F_c), although F itself may be tensile.
  ContactState<double> s{{0, 0, 1}, d, {1.0, 0, 0}, {0, 0, 0}, R, 1e-5, 1e-10, 2 * R};
  const auto out = hertzMindlin<true, false, true>(p, s, Vec3d{-1e-3, 0, 0}, 1e-6);
  EXPECT_TRUE(out.sliding);
  EXPECT_NEAR(norm(out.tangentialForce), mu * np.load, 1e-9 * fc);
  // Without adhesion the kernel with adhesion computes what the one without does, to the bit.
  ContactParams plain = adhesive(cohesion::kNone, 0.0, 0.5, mu);
  const auto a = hertzMindlin<true, true, true>(plain, s, Vec3d{1e-9, 2e-9, 0}, 1e-6);
  const auto b = hertzMindlin<true, true, false>(plain, s, Vec3d{1e-9, 2e-9, 0}, 1e-6);
  EXPECT_EQ(a.force.x, b.force.x);
  EXPECT_EQ(a.force.z, b.force.z);
  EXPECT_EQ(a.torque.y, b.torque.y);
}

}  // namespace
}  // namespace pflow::compute::contact
