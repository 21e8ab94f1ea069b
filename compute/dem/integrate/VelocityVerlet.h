// Velocity Verlet for translation and rotation of spheres (moment of inertia 2/5 m R^2):
//   first half:  v += (F/m + g) dt/2,  x += v dt,  w += T/I dt/2
//   (forces at the new positions with the half-step velocities)
//   second half: v += (F/m + g) dt/2,  w += T/I dt/2
// A step's second half may be deferred into the next step's first (IntegrateBothHalves; Simulation decides when).
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/core/VectorMath.h"

namespace pflow::compute::kernels {

// acc + dx rounded away from zero: a float sum would drop every step below half a unit in the last place
// of the total (3.6e-12 m at 6e-5 m), so a particle creeping slowly enough would never reach the skin and
// its contacts would go unseen. Rounded up in magnitude, the accumulator can only over-read, by at most
// one unit in the last place per step: negligible where a step moves more than that (7e-12 m at 1e-4 m);
// a particle creeping slower advances the accumulator one unit per step and triggers a rebuild early, at
// most once per ~10^7 steps (2^23 steps per binary order of magnitude).
// The step away from zero is done on the bits (a float's magnitude is monotonic in its bit pattern), not
// by nextafterf: a library call on the host, which kept this loop from vectorising and cost a sixth of
// the CPU step.
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE float addUp(float acc, double dx) {
  const double exact = double(acc) + dx;
  const float f = float(exact);
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  // One unit in the last place further from zero is the magnitude's bits + 1, also from (signed) zero,
  // whose sign float() keeps. Added without a branch: which way float() rounded is a coin toss per step.
  bits += std::uint32_t(std::fabs(double(f)) < std::fabs(exact));
  float out;
  std::memcpy(&out, &bits, sizeof out);
  return out;
}

// R: the run's precision for velocities, spins, forces, radius and mass; positions are double.
template <class R>
struct IntegrateArgs {
  Vec3d* pos;
  Vec3<R>* vel;
  Vec3<R>* omega;
  const Vec3<R>* force;
  const Vec3<R>* torque;
  const R* radius;
  const R* mass;
  Vec3f* moved;  // displacement since the last neighbour rebuild, rounded up in magnitude (addUp): the skin test
  Vec3d gravity;
  double dt;
  Conditions* cond;
  int planarAxis = -1;  // 2D (ModelFlags): 0, 1, 2 keeps the motion in the plane normal to that axis
  // The scene's explicit simulation.domain (checkDomain): a centre outside it is flagged (kLeftDomain).
  bool checkDomain = false;
  Vec3d domainLo{0, 0, 0}, domainHi{0, 0, 0};
  // Fixed materials (MaterialConfig::fixed), a bit each: their particles keep zero velocity and spin. 0: none (the
  // material is not read).
  const std::int32_t* material = nullptr;
  std::uint64_t fixedMask = 0;

  // 2D: no velocity along the axis, spin only about it, so round-off cannot break the plane's symmetry.
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void keepPlanar(Vec3<R>& v, Vec3<R>& w) const {
    if (planarAxis == 0) { v.x = R(0); w.y = R(0); w.z = R(0); }
    else if (planarAxis == 1) { v.y = R(0); w.x = R(0); w.z = R(0); }
    else if (planarAxis == 2) { v.z = R(0); w.x = R(0); w.y = R(0); }
  }

  // Half kick of particle i from (v0, w0): v = v0 + (F/m + g) dt/2 and w = w0 + T/I dt/2, with I = (2/5) m r^2.
  // Every multiply-add is an explicit fused one: left to the compiler, whether one is fused depends on the code
  // around it (IntegrateBothHalves' drift came out unfused where IntegrateFirstHalf's was fused), and the two passes
  // must give the same bits (as the executors do).
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void halfKick(Index i, Vec3<R> v0, Vec3<R> w0, Vec3<R>& v, Vec3<R>& w) const {
    if (fixedMask != 0 && (fixedMask >> std::uint32_t(material[i]) & 1u)) {
      v = w = Vec3<R>{R(0), R(0), R(0)};
      return;
    }
    const R h = R(0.5 * dt);
    const R invM = R(1) / mass[i];
    const R hI = h * (invM / (R(0.4) * radius[i] * radius[i]));
    const Vec3<R> f = force[i], t = torque[i];
    const Vec3<R> g = vcast<R>(gravity);
    v = {std::fma(h, std::fma(invM, f.x, g.x), v0.x), std::fma(h, std::fma(invM, f.y, g.y), v0.y),
         std::fma(h, std::fma(invM, f.z, g.z), v0.z)};
    w = {std::fma(hI, t.x, w0.x), std::fma(hI, t.y, w0.y), std::fma(hI, t.z, w0.z)};
    keepPlanar(v, w);
  }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void halfKick(Index i, Vec3<R>& v, Vec3<R>& w) const { halfKick(i, vel[i], omega[i], v, w); }

  // The drift of the first half: x += v dt, and the displacement since the last rebuild; returns its square.
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE double drift(Index i, Vec3<R> v) const {
    const Vec3d dx = dt * vcast<double>(v), x = pos[i];
    pos[i] = {std::fma(dt, double(v.x), x.x), std::fma(dt, double(v.y), x.y), std::fma(dt, double(v.z), x.z)};
    const Vec3f m = moved[i];
    const Vec3f mv{addUp(m.x, dx.x), addUp(m.y, dx.y), addUp(m.z, dx.z)};
    moved[i] = mv;
    return norm2(vcast<double>(mv));
  }

  // The second half's checks, on the state at the step's end: one test on a sum (NaN and infinity propagate through
  // it, so it is finite only if every term is), and the centre against the scene's domain. False: flagged.
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool checkEnd(Index i, Vec3d x, Vec3<R> v, Vec3<R> w) const {
    bool ok = true;
    const Vec3<R> f = force[i], t = torque[i];
    const R sum = R(x.x + x.y + x.z) + v.x + v.y + v.z + w.x + w.y + w.z + f.x + f.y + f.z + t.x + t.y + t.z;
    if (!std::isfinite(sum)) {
      atomicOrU32(&cond->flags, kNonFinite);
      atomicMinU32(&cond->badParticle, i);
      ok = false;
    }
    if (checkDomain && (x.x < domainLo.x || x.y < domainLo.y || x.z < domainLo.z || x.x > domainHi.x ||
                        x.y > domainHi.y || x.z > domainHi.z)) {
      atomicOrU32(&cond->flags, kLeftDomain);
      atomicMinU32(&cond->outsideParticle, i);
      ok = false;
    }
    return ok;
  }
};

// Returns the squared displacement since the last rebuild (for the skin criterion).
template <class R>
struct IntegrateFirstHalf {
  IntegrateArgs<R> a;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    Vec3<R> v, w;
    a.halfKick(i, v, w);
    a.vel[i] = v;
    a.omega[i] = w;
    return a.drift(i, v);
  }
};

template <class R>
struct IntegrateSecondHalf {
  IntegrateArgs<R> a;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    Vec3<R> v, w;
    a.halfKick(i, v, w);
    a.vel[i] = v;
    a.omega[i] = w;
    a.checkEnd(i, a.pos[i], v, w);
  }
};

// The last step's second half (with its checks) and this step's first half in one pass (Simulation's deferred second
// half): the same operations on the same values as IntegrateSecondHalf followed by IntegrateFirstHalf, so the same
// bits, but v, w, F, T, m and r are read once and v and w written once instead of twice.
template <class R>
struct IntegrateBothHalves {
  IntegrateArgs<R> a;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    Vec3<R> v1, w1, v, w;
    a.halfKick(i, v1, w1);
    if (!a.checkEnd(i, a.pos[i], v1, w1)) {  // the run stops: its report describes the particle at the step's end
      a.vel[i] = v1;
      a.omega[i] = w1;
      return 0.0;
    }
    a.halfKick(i, v1, w1, v, w);
    a.vel[i] = v;
    a.omega[i] = w;
    return a.drift(i, v);
  }
};

// Kinetic energy of particle i, translational plus rotational (I = 2/5 m r^2) [J] (sumOf).
template <class R>
struct KineticEnergy {
  const Vec3<R>* vel;
  const Vec3<R>* omega;
  const R* mass;
  const R* radius;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    const double m = double(mass[i]), r = double(radius[i]);
    return 0.5 * m * norm2(vcast<double>(vel[i])) + 0.2 * m * r * r * norm2(vcast<double>(omega[i]));
  }
};

// Mass of particle i when its centre lies past the plane through `point` along `normal` (unit), else 0 [kg]
// (sumOf): the mass downstream of a flow plane, whose growth is the mass flow through it.
template <class R>
struct MassPastPlane {
  const Vec3d* pos;
  const R* mass;
  Vec3d point, normal;
  PFLOW_HOSTDEVICE double operator()(Index i) const { return dot(pos[i] - point, normal) > 0 ? double(mass[i]) : 0.0; }
};

// Gravitational potential energy of particle i relative to the point `origin`, -m g.(x - origin) [J] (sumOf).
template <class R>
struct PotentialEnergy {
  const Vec3d* pos;
  const R* mass;
  Vec3d gravity, origin;
  PFLOW_HOSTDEVICE double operator()(Index i) const { return -double(mass[i]) * dot(gravity, pos[i] - origin); }
};

// Kinetic plus gravitational energy of particle i [J] (sumOf): the energy detector's one pass.
template <class R>
struct MechanicalEnergy {
  KineticEnergy<R> kinetic;
  PotentialEnergy<R> potential;
  PFLOW_HOSTDEVICE double operator()(Index i) const { return kinetic(i) + potential(i); }
};

}  // namespace pflow::compute::kernels
