// Contact physics, written once as stateless host+device functions over plain structs, split into
// sub-models the way LAMMPS's granular model is (normal with its dashpot, tangential, rolling).
//
// Conventions: n is the unit normal from particle i towards its partner j (for a wall, towards the
// wall); overlap delta > 0 in contact; vRel = velocity of i's contact point minus j's; forces and
// torques returned act on i. Velocity-dependent terms use the velocities they are given (the
// half-step velocities in the velocity-Verlet loop, as LAMMPS and LIGGGHTS do).
#pragma once
#include <cmath>
#include <type_traits>

#include "compute/core/FastMath.h"
#include "compute/dem/contact/ContactParams.h"
#include "compute/core/VectorMath.h"

namespace pflow::compute::contact {

// Geometry and kinematics of one contact as seen from particle i.
template <class T>
struct ContactState {
  Vec3<T> n;          // unit normal, i -> j
  T overlap;          // delta > 0 [m]
  Vec3<T> vRel;       // contact-point velocity of i minus that of j [m/s]
  Vec3<T> omegaRel;   // omega_i - omega_j [rad/s]
  T effRadius;        // R* [m]
  T effMass;          // m* [kg]
  T effInertia;       // 1 / (1/I_i + 1/I_j) [kg m^2], for the rolling-torque limiter
  T leverArm;         // distance from i's centre to the contact point [m]
};

template <class T>
struct ContactOutput {
  Vec3<T> force;            // on i [N]; the partner feels -force
  Vec3<T> torque;           // on i about its centre [N m]: (leverArm n) x tangentialForce + rollingTorque
  Vec3<T> tangentialForce;  // the tangential part of `force` [N]
  Vec3<T> rollingTorque;    // rolling resistance on i [N m]; the partner feels its negative
  Vec3<T> history;    // new tangential displacement xi [m]
  T normalForce;      // F_n along -n [N]: >= 0 without adhesion (clipped), negative when adhesion pulls
  bool sliding;       // Coulomb cap active
};

namespace normal {
// Hertz elastic force magnitude (4/3) E* sqrt(R*) delta^{3/2}.
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T hertzForce(T effYoung, T effRadius, T overlap) {
  return T(4) / T(3) * effYoung * std::sqrt(effRadius * overlap) * overlap;
}
// Normal stiffness S_n = dF/d delta = 2 E* sqrt(R* delta).
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T hertzStiffness(T effYoung, T effRadius, T overlap) {
  return T(2) * effYoung * std::sqrt(effRadius * overlap);
}
// Elastic energy stored in a Hertz contact, (8/15) E* sqrt(R*) delta^{5/2}.
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T hertzEnergy(T effYoung, T effRadius, T overlap) {
  return T(8) / T(15) * effYoung * std::sqrt(effRadius) * overlap * overlap * std::sqrt(overlap);
}

// a / b for the dashpot's float corrections: correctly rounded in double runs (the same bits on both executors,
// which double runs are held to), the special-function unit's quotient in float runs on the GPU (divFast; float
// runs agree across executors to float's rounding only).
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE float dashpotQuotient(float a, float b) {
  if constexpr (std::is_same_v<T, float>) return divFast(a, b);
  return a / b;
}

// The normal dashpot's force over one step, integrated so that the discrete step restitutes what the continuous
// contact does. The dashpot C delta^{1/4} vn (C = c sqrt(2 E* sqrt(R*) m*)) is the time derivative of
// (4/5) C delta^{5/4}, so its impulse over any interval is exact from the overlaps at its ends: this returns that
// impulse over the step just taken (from the overlap a step ago, delta - vn dt, clipped at 0: a contact that began
// within the step counts from its first touch, wherever in the step that fell) divided by dt. Applying
// C delta^{1/4} vn at the half-step velocity instead (as before) made the restitution depend at first order on
// where in a step the contact began (-1.4 % to -4.5 % at e = 0.1 with 64 steps per contact); what this leaves is
// smooth in the step and calibrated away (the factor in hertzNormal). It is continuous in the state: 0 at first touch.
// dampN = C delta^{1/4} (the continuous coefficient). Most evaluations (|vn dt| <= delta / 4) take the quotient
// (a^{5/4} - b^{5/4}) / (a - b) from its series in eps = vn dt / delta (to 2e-7), the others from the fourth root
// of the overlaps' ratio, without cancellation. Returns the force along -n on i (positive when approaching). For the
// tangential dashpot, which must act over the same part of the step: `touch`, the part of the step in contact (below 1
// only on a contact's first step), and `share`, the step's mean of delta^{1/4} over its end value counted over the
// whole step (4/5 of the part in contact on a first step). Both are continuous in the state, across the two branches
// too (a jump there, tried, made CPU and GPU trajectories part: a flip of branch by rounding became a 3 % jump of the
// tangential damping). The first step's quotient is the division the fourth roots need anyway.
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T stepDashpot(T dampN, T overlap, T vn, T dt, T& share, T& touch) {
  const T step = vn * dt;  // the overlap gained over the step
  share = touch = T(1);
  if (T(16) * step * step <= overlap * overlap) {
    // (1 - (1 - eps)^{5/4}) / (5/4 eps) to eps^6. A relative correction below 4 % needs no more than float,
    // formed by operations that round alike on every executor in double runs (a correctly rounded quotient,
    // explicit fused multiply-adds).
    const float e = dashpotQuotient<T>(float(step), float(overlap));
    float c = std::fma(e, -0.0031890869140625f, -0.00469970703125f);
    c = std::fma(e, c, -0.00751953125f);
    c = std::fma(e, c, -0.013671875f);
    c = std::fma(e, c, -0.03125f);
    c = std::fma(e, c, -0.125f);
    share = T(std::fma(e, c, 1.0f));
    return dampN * vn * share;
  }
  // Beyond: with r = (overlap a step ago) / overlap and q = r^{1/4}, (1 - r^{5/4}) / (1 - r) is
  // (1 + q + q^2 + q^3 + q^4) / ((1 + q)(1 + q^2)), without cancellation; 4/5 of it is 1 at r = 1. On a first step
  // (the overlap a step ago clipped at 0) r = 0, and the one quotient is the part of the step in contact instead.
  const bool first = !(overlap > step);
  const T before = first ? T(0) : overlap - step;
  const T quotient = first ? overlap / step : before / overlap;
  const T q = first ? T(0) : std::sqrt(std::sqrt(quotient));
  const T q2 = q * q;
  const T ratio = (T(1) + q + q2 + q * q2 + q2 * q2) / ((T(1) + q) * (T(1) + q2));
  if (first) touch = quotient;
  share = T(0.8) * ratio * touch;
  return T(0.8) * dampN * ((overlap - before) / dt) * ratio;
}

// The same, without the tangential dashpot's share.
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T stepDashpot(T dampN, T overlap, T vn, T dt) {
  T share, touch;
  return stepDashpot(dampN, overlap, vn, dt, share, touch);
}

// The normal force magnitude on a contact, clipped at zero: Hertz elastic (4/3) E* sqrt(R*) delta^{3/2} plus the
// dashpot (stepDashpot) with coefficient c (1 + a1 u + a2 u^2 + a3 u^3) sqrt(S_n m*), where u = omega dt is the
// step in units of the contact's present normal frequency omega = sqrt(S_n / m*) (clamped at 0.75) and
// (a1, a2, a3) = ContactParams::dashpotStep, fitted so that the discrete step restitutes e (calibrateDashpotForStep).
// u comes from what the dashpot needs anyway (omega dt = c sqrt(S_n m*) dt / (c m*)): no extra root.
// sqrtRd = sqrt(R* delta). Also returns, for the tangential dashpot, the continuous dashpot's coefficient
// c sqrt(S_n m*) times stepDashpot's share in `dampN`, and the part of the step in contact in `touch` (1 without a dashpot).
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T hertzNormal(const ContactParams& p, T overlap, T sqrtRd, T vn, T effMass, T dt,
                                                 T& dampN, T& touch) {
  const T E = T(p.effYoung), c = T(p.dampingCoeff);
  const T sn = T(2) * E * sqrtRd;
  T fn = T(4) / T(3) * E * sqrtRd * overlap;
  dampN = c * sqrtFast(sn * effMass);
  touch = T(1);
  if (c > T(0)) {
    // The factor in float, by operations that round alike on every executor in double runs (as stepDashpot's series).
    float u = dashpotQuotient<T>(float(dampN) * float(dt), float(c) * float(effMass));
    if (u > 0.75f) u = 0.75f;
    const float factor = std::fma(
        u, std::fma(u, std::fma(u, float(p.dashpotStep[2]), float(p.dashpotStep[1])), float(p.dashpotStep[0])), 1.0f);
    // No dashpot can do more within one step than stop the relative normal motion: where a contact is resolved by
    // a handful of steps the explicit dashpot would otherwise overshoot and reverse it (the damping instability
    // of strongly damped contacts, docs/accuracy.md). Inactive at 12 or more steps per contact for e >= 0.1.
    T share;
    T fd = stepDashpot(T(factor) * dampN, overlap, vn, dt, share, touch);
    dampN *= share;  // the tangential dashpot's coefficient over the same step: the normal's mean over it
    const T mv = effMass * (vn < T(0) ? -vn : vn);
    if ((fd < T(0) ? -fd : fd) * dt > mv) fd = (fd < T(0) ? -mv : mv) / dt;
    fn += fd;
  }
  return fn > T(0) ? fn : T(0);
}
}  // namespace normal

namespace tangential {
// Rotates the stored displacement into the tangent plane of the current normal, keeping its length.
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> rotateHistory(Vec3<T> xi, Vec3<T> n) {
  const T len2 = norm2(xi);
  if (len2 == T(0)) return xi;
  Vec3<T> p = xi - dot(xi, n) * n;
  const T p2 = norm2(p);
  // Nearly parallel to the normal: the direction is round-off, so forget it rather than amplify it.
  if (p2 <= T(1e-12) * len2) return zero3<T>();
  return sqrtFast(len2 / p2) * p;
}
// Mindlin spring S_t = 8 G* sqrt(R* delta).
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T mindlinStiffness(T effShear, T effRadius, T overlap) {
  return T(8) * effShear * std::sqrt(effRadius * overlap);
}
// Spring-dashpot with Coulomb cap. xi is already rotated and incremented by vt dt. Returns the
// tangential force on i; when |F_t| > mu F_n the force is capped and xi reset so that the spring
// alone carries the capped force.
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> mindlinForce(T stiffness, T dampCoeff, T friction, T normalForce,
                                                        Vec3<T> vt, Vec3<T>& xi, bool& sliding) {
  Vec3<T> ft = -(stiffness * xi) - dampCoeff * vt;
  const T cap = friction * normalForce;
  const T ft2 = norm2(ft);
  sliding = ft2 > cap * cap;
  if (sliding) {
    ft = (ft2 > T(0) ? cap / sqrtFast(ft2) : T(0)) * ft;
    xi = stiffness > T(0) ? (T(-1) / stiffness) * ft : zero3<T>();
  }
  return ft;
}
}  // namespace tangential

namespace rolling {
// Constant directional torque ("type A"): -mu_r F_n R* w/|w| for the rolling part w of the relative
// spin (its component normal to the contact removed by the caller), limited so that it cannot reverse the
// relative spin within one step (|tau| <= I* |w| / dt), which removes the sign chatter at rest.
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> constantTorque(T rollingFriction, T normalForce, T effRadius,
                                                          Vec3<T> omegaRel, T effInertia, T dt) {
  const T w = sqrtFast(norm2(omegaRel));
  if (rollingFriction <= T(0) || w == T(0)) return zero3<T>();
  T mag = rollingFriction * normalForce * effRadius;
  const T limit = divFast(effInertia * w, dt);
  if (mag > limit) mag = limit;
  return (-mag / w) * omegaRel;
}
}  // namespace rolling

namespace cohesion {
inline constexpr int kNone = 0, kJkr = 1, kConstant = 2;  // ContactParams::cohesion

// JKR (Johnson, Kendall & Roberts 1971): a contact of radius a has overlap delta = a^2/R* - B sqrt(a) with
// B = sqrt(2 pi dgamma / E*), and normal force (4/3) E* a^3 / R* - 2 E* B a^{3/2} (= sqrt(8 pi dgamma E* a^3)).
// With s = sqrt(a) everything is polynomial in s: s^3 is B R* at delta = 0 (a0), 3/2 B R* where the force is 0,
// and B R* / 4 at the break point delta_c = -(3/4) B^{4/3} (R*/4)^{1/3} (ContactParams::jkrBreak).

// sqrt(a) on the stable branch for overlap delta >= delta_c: the root of f(s) = s^4/R* - B s - delta (convex and
// increasing past the break point) by Halley's method (cubic convergence: three steps from the start below reach
// rounding, against four or five of Newton's; 25 % less time on the CPU). The start is above the root: the nearer of
// y + x with y = (B R*)^{1/3}, x = (R* delta)^{1/4} ((x + y)^4 exceeds x^4 + y^3 (x + y) term by term; exact at
// delta = 0 and tight when either term dominates) and max(2^{1/3} y, 2^{1/4} x) (s^4/R* at least twice each of B s
// and delta; within 3 % where the two are alike). At the break point itself the root is double and convergence
// linear: there the result is good to the tolerance (1e-6 in double; the force to ~2e-6 of F_c).
// sqrtRd: sqrt(R* delta) where delta > 0 (the caller has it), else anything.
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T jkrRootRadius(T B, T effRadius, T overlap, T sqrtRd) {
  const T y = std::cbrt(B * effRadius);
  T s = T(1.2599210498948732) * y;
  if (overlap > T(0)) {
    const T x = std::sqrt(sqrtRd);
    const T hi = T(1.189207115002721) * x > s ? T(1.189207115002721) * x : s;
    s = x + y < hi ? x + y : hi;
  }
  const T invR = T(1) / effRadius;
  const T tol = std::is_same_v<T, float> ? T(2e-3) : T(1e-6);  // cubic: the error left is ~ tol^3
  for (int it = 0; it < 60; ++it) {
    const T s2 = s * s, s3 = s2 * s;
    const T f = s3 * s * invR - B * s - overlap;
    const T slope = T(4) * s3 * invR - B;
    const T den = T(2) * slope * slope - f * (T(12) * s2 * invR);
    if (!(slope > T(0)) || !(den > T(0))) break;  // at the break point (round-off)
    const T ds = T(2) * f * slope / den;
    s -= ds;
    if ((ds < T(0) ? -ds : ds) <= tol * s) break;
  }
  return s;
}
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T jkrRootRadius(T B, T effRadius, T overlap) {
  return jkrRootRadius(B, effRadius, overlap, overlap > T(0) ? std::sqrt(effRadius * overlap) : T(0));
}
// The JKR normal force (positive repulsive) at s = sqrt(a).
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T jkrForce(T effYoung, T B, T effRadius, T s) {
  const T s3 = s * s * s;
  return effYoung * s3 * (T(4) / T(3) * s3 / effRadius - T(2) * B);
}
// The overlap at which a JKR contact breaks (negative): -jkrBreak R*^{1/3}.
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T jkrBreakOverlap(T jkrBreak, T effRadius) {
  return -jkrBreak * std::cbrt(effRadius);
}
// The work done on the contact from its formation at delta = 0 to the state s = sqrt(a) along the JKR branch,
// Phi = G(a) - G(a0) with G(a) = (8/15) E* a^5 / R*^2 - (4/3) E* B a^{7/2} / R* + (1/2) E* B^2 a^2
// (dG/d delta = the JKR force). Negative in the adhesive well; at the break point it is the energy a contact
// loses by breaking (the JKR hysteresis, which decides the sticking velocity).
template <class T> PFLOW_HOSTDEVICE inline T jkrEnergy(T effYoung, T B, T effRadius, T s) {
  auto g = [&](T q) {
    const T q2 = q * q, q4 = q2 * q2;
    return effYoung * q4 * (T(8) / T(15) * q4 * q2 / (effRadius * effRadius) - T(4) / T(3) * B * q2 * q / effRadius +
                            T(0.5) * B * B);
  };
  return g(s) - g(std::cbrt(B * effRadius));
}
// DMT's constant adhesion 2 pi dgamma R* (= E* B^2 R*), for the constant model.
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T constantAdhesion(T effYoung, T B, T effRadius) {
  return effYoung * B * B * effRadius;
}
}  // namespace cohesion

// The normal part of a contact, for the tangential and rolling parts that follow it.
template <class T>
struct NormalPart {
  T force;          // along -n on i (positive repulsive; negative when adhesion pulls)
  T damp;           // the continuous dashpot's coefficient c sqrt(S_n m*) over the step (the tangential dashpot's scale)
  T touch;          // the part of the step in contact (below 1 on a damped contact's first step; hertzNormal)
  T contactRadius;  // a [m]: sqrt(R* delta) for Hertz, JKR's a with adhesion (the Mindlin stiffness is 8 G* a)
  T load;           // what the Coulomb cap and rolling resistance scale with: the force, plus 2 F_c for JKR
                    // (Thornton & Yin 1991) or the constant adhesion for DMT, never negative
};

// The normal part: Hertz with the step dashpot, clipped at zero; with adhesion (kCohesion, ContactParams::cohesion)
// the adhesive force is added to it: JKR's force in place of Hertz's, or DMT's constant pull. A JKR contact holds
// at negative overlap down to its break point (the caller keeps it, from its history slot); the dashpot acts only
// while delta > 0.
template <bool kCohesion, class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE NormalPart<T> normalPart(const ContactParams& p, T overlap, T effRadius, T vn, T effMass,
                                                            T dt) {
  NormalPart<T> out;
  if constexpr (kCohesion) {
    if (p.cohesion != cohesion::kNone) {
      const T E = T(p.effYoung), B = T(p.jkrB);
      T fd = T(0), sqrtRd = T(0);
      out.damp = T(0);
      out.touch = T(1);
      if (overlap > T(0)) {  // Hertz and its dashpot, clipped; the dashpot's share kept
        sqrtRd = sqrtFast(effRadius * overlap);
        fd = normal::hertzNormal(p, overlap, sqrtRd, vn, effMass, dt, out.damp, out.touch);
      }
      if (p.cohesion == cohesion::kJkr) {
        const T s = cohesion::jkrRootRadius(B, effRadius, overlap, sqrtRd);
        if (overlap > T(0)) fd -= T(4) / T(3) * E * sqrtRd * overlap;  // the Hertz part hertzNormal added
        out.force = cohesion::jkrForce(E, B, effRadius, s) + fd;
        out.contactRadius = s * s;
        const T lift = out.force + T(1.5) * E * B * B * effRadius;  // F + 2 F_c, F_c = (3/2) pi dgamma R*
        out.load = lift > T(0) ? lift : T(0);
      } else {
        const T f0 = cohesion::constantAdhesion(E, B, effRadius);
        out.force = fd - f0;
        out.contactRadius = sqrtRd;
        out.load = fd;
      }
      return out;
    }
  }
  const T sqrtRd = sqrtFast(effRadius * overlap);
  out.force = normal::hertzNormal(p, overlap, sqrtRd, vn, effMass, dt, out.damp, out.touch);
  out.contactRadius = sqrtRd;
  out.load = out.force;
  return out;
}

// Hertz-Mindlin with history: normal elastic + dashpot (clipped at zero), tangential Mindlin spring
// with history and Coulomb cap, optional rolling resistance, optional adhesion. `xiOld` is the stored displacement.
// kTangential = false leaves the tangential part out (the least model when every friction is 0: the Coulomb
// cap would make that force exactly 0), kRolling = false the rolling torque (every rolling friction 0),
// kCohesion = false adhesion (no pair asks for it).
template <bool kTangential = true, bool kRolling = true, bool kCohesion = false, class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE ContactOutput<T> hertzMindlin(const ContactParams& p, const ContactState<T>& s,
                                                                 Vec3<T> xiOld, T dt) {
  ContactOutput<T> out;
  const T G = T(p.effShear);
  // Normal: positive vn means approaching.
  const T vn = dot(s.vRel, s.n);
  const NormalPart<T> np = normalPart<kCohesion>(p, s.overlap, s.effRadius, vn, s.effMass, dt);
  out.normalForce = np.force;
  Vec3<T> force = (-np.force) * s.n;

  if constexpr (kTangential) {
    const Vec3<T> vt = s.vRel - vn * s.n;
    // The displacement over the part of the step in contact: from the first touch on a damped contact's first step
    // (the normal dashpot's rule), so that where in a step a contact begins does not add a step of spring.
    Vec3<T> xi = tangential::rotateHistory(xiOld, s.n) + (dt * np.touch) * vt;
    const T st = T(8) * G * np.contactRadius;
    const Vec3<T> ft =
        tangential::mindlinForce(st, np.damp * T(p.tangentialRatio), T(p.friction), np.load, vt, xi, out.sliding);
    force += ft;
    out.history = xi;
    out.tangentialForce = ft;
    out.torque = cross(s.leverArm * s.n, ft);
  } else {
    (void)G;
    (void)xiOld;
    out.history = zero3<T>();
    out.tangentialForce = zero3<T>();
    out.torque = zero3<T>();
    out.sliding = false;
  }
  out.force = force;
  out.rollingTorque = zero3<T>();
  if (kRolling && p.rollingFriction > 0) {
    // Rolling resists the relative spin about tangent axes only; twisting about n is not rolling.
    const Vec3<T> wRoll = s.omegaRel - dot(s.omegaRel, s.n) * s.n;
    out.rollingTorque = rolling::constantTorque(T(p.rollingFriction), np.load, s.effRadius, wRoll, s.effInertia, dt);
    out.torque += out.rollingTorque;
  }
  return out;
}

// The torque of the same contact on the partner j about j's centre, from i's evaluation (a pair evaluated
// once): j's contact point lies -leverArmJ n from its centre and j feels -F_t, so the sliding part is
// (-leverArmJ n) x (-F_t) = leverArmJ (n x F_t); the rolling couple acts on j the other way.
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> partnerTorque(const ContactOutput<T>& out, Vec3<T> n, T leverArmJ) {
  return cross(leverArmJ * n, out.tangentialForce) - out.rollingTorque;
}

}  // namespace pflow::compute::contact
