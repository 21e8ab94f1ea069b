// The SPH engine's time-integration kernels (docs/sph.md, "Time integration"): the symplectic predictor and
// corrector, Monaghan's Verlet, velocity Verlet's kick-drift and kick, the end-of-step checks and the next step's
// limit. One particle per call, PFLOW_HOSTDEVICE, run by either executor; the rates they read are SphKernels.h's.
#pragma once
#include <cmath>
#include <cstdint>

#include "compute/core/Conditions.h"
#include "compute/sph/SphKernels.h"

namespace pflow::compute::sph::kernels {

// The fields both halves of the symplectic step update.
template <class R>
struct StepArgs {
  Vec3d* pos;
  Vec3<R>* vel;
  R* rho;
  R* p;
  const Vec3<R>* acc;
  const R* drho;
  const std::int32_t* kind;
  Vec3d* pos0;
  Vec3<R>* vel0;
  R* rho0;
  const Vec3d* ref;  // positions at the last cell sort (the skin criterion)
  Tait<R> eos;
  double dt;
  // Boundary particles never fall below rho0 (Crespo et al. 2007 / DualSPHysics: walls must not attract).
  R boundaryFloor;
  R minDensity, maxDensity;  // a fluid particle outside [min, max] stops the run (corrector)
  // Leak check: a fluid particle below the walls' top (boxHi.z) and outside this box (the tank's outer walls)
  // has passed through a wall or spilled over an open top; above the walls' top it may be anywhere.
  bool checkBox = false;
  Vec3d boxLo{0, 0, 0}, boxHi{0, 0, 0};
  MirrorWalls mirror;  // a fluid particle past a mirror wall is put back (MirrorWalls::keepInside)
  // sph.boundary_density: mdbc: the boundary particles' density and pressure are the extrapolation's
  // (kernels::MdbcDensity, before each evaluation of the rates), not integrated: these kernels leave them.
  bool extrapolatedBoundary = false;
  Conditions* cond = nullptr;
};

// Predictor: the state at the start of the step is kept, and x, v, rho advance half a step with the rates of
// that state: v = v0 + dt/2 a, x = x0 + dt/2 v0, rho = rho0 + dt/2 drho; p from the equation of state.
// Returns the squared displacement since the last cell sort.
template <class R>
struct Predictor {
  StepArgs<R> a;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    const R h = R(0.5 * a.dt);
    const Vec3d x0 = a.pos[i];
    const R r0 = a.rho[i];
    a.pos0[i] = x0;
    a.rho0[i] = r0;
    R r = r0 + h * a.drho[i];
    if (a.kind[i] == kFluid) {
      const Vec3<R> v0 = a.vel[i];
      a.vel0[i] = v0;
      Vec3<R> v = v0 + h * a.acc[i];
      Vec3d x = x0 + (0.5 * a.dt) * vcast<double>(v0);
      if (a.mirror.any) a.mirror.keepInside(x, v);
      a.vel[i] = v;
      a.pos[i] = x;
    } else if (a.extrapolatedBoundary) {
      return norm2(a.pos[i] - a.ref[i]);
    } else if (r < a.boundaryFloor) {
      r = a.boundaryFloor;
    }
    a.rho[i] = r;
    a.p[i] = a.eos.pressure(r);
    return norm2(a.pos[i] - a.ref[i]);
  }
};

// The checks at the end of a step: non-finite values, densities out of bounds and leaks are flagged with the
// lowest offending index.
template <class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void checkState(const StepArgs<R>& a, Index i, bool fluid, const Vec3d& x, const Vec3<R>& v, R r) {
  if (fluid) {
    if (!isFinite(x) || !isFinite(v) || !std::isfinite(r)) {
      atomicOrU32(&a.cond->flags, kNonFinite);
      atomicMinU32(&a.cond->badParticle, i);
    } else if (r < a.minDensity || r > a.maxDensity) {
      atomicOrU32(&a.cond->flags, kDensityOutOfRange);
      atomicMinU32(&a.cond->densityParticle, i);
    }
    if (a.checkBox && x.z < a.boxHi.z &&
        (x.x < a.boxLo.x || x.y < a.boxLo.y || x.z < a.boxLo.z || x.x > a.boxHi.x || x.y > a.boxHi.y)) {
      atomicOrU32(&a.cond->flags, kLeftDomain);
      atomicMinU32(&a.cond->outsideParticle, i);
    }
  } else if (!std::isfinite(r)) {
    atomicOrU32(&a.cond->flags, kNonFinite);
    atomicMinU32(&a.cond->badParticle, i);
  }
}

// The end of a step for particle i: a fluid particle's new x and v put back inside the mirrors and stored, a boundary
// particle's density floored, every value checked (checkState), the density and pressure stored. Returns the
// squared displacement since the last cell sort.
template <class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE double finishStep(const StepArgs<R>& a, Index i, bool fluid, Vec3d x, Vec3<R> v, R r) {
  if (fluid) {
    if (a.mirror.any) a.mirror.keepInside(x, v);
    a.vel[i] = v;
    a.pos[i] = x;
  } else if (a.extrapolatedBoundary) {
    return norm2(x - a.ref[i]);
  } else if (r < a.boundaryFloor) {
    r = a.boundaryFloor;
  }
  checkState(a, i, fluid, x, v, r);
  a.rho[i] = r;
  a.p[i] = a.eos.pressure(r);
  return norm2(x - a.ref[i]);
}

// Corrector, with the rates at the half step: rho = rho0 (2 - eps)/(2 + eps), eps = -drho/rho dt;
// v = v0 + dt a; x = x0 + dt (v + v0)/2; finished by finishStep.
template <class R>
struct Corrector {
  StepArgs<R> a;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    const R dt = R(a.dt);
    const R eps = -a.drho[i] / a.rho[i] * dt;
    R r = a.rho0[i] * (R(2) - eps) / (R(2) + eps);
    const bool fluid = a.kind[i] == kFluid;
    Vec3d x = a.pos[i];
    Vec3<R> v = a.vel[i];
    if (fluid) {
      const Vec3<R> v0 = a.vel0[i];
      v = v0 + dt * a.acc[i];
      x = a.pos0[i] + (0.5 * a.dt) * vcast<double>(v + v0);
    }
    return finishStep(a, i, fluid, x, v, r);
  }
};

// One Verlet step with the rates of the state now (n), from the state before it (n - 1, kept in vel0 and rho0):
// v' = v(n-1) + (dt' + dt) a, rho' = rho(n-1) + (dt' + dt) drho, x' = x + dt v + dt^2/2 a, dt' the step before
// (Monaghan 1989, Crespo et al. 2015, who write 2 dt: the same at a constant step); an Euler step (`dtBefore` 0:
// v' = v + dt a, rho' = rho + dt drho) every sph.verlet_steps steps and at the first. The state now becomes the
// one before. Finished by finishStep.
template <class R>
struct VerletStep {
  StepArgs<R> a;
  double dtBefore;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    const bool euler = dtBefore == 0;
    const R span = R(euler ? a.dt : a.dt + dtBefore);
    const R rNow = a.rho[i];
    R r = (euler ? rNow : a.rho0[i]) + span * a.drho[i];
    a.rho0[i] = rNow;
    const bool fluid = a.kind[i] == kFluid;
    Vec3d x = a.pos[i];
    Vec3<R> v = a.vel[i];
    if (fluid) {
      const Vec3<R> vNow = v, acc = a.acc[i];
      v = (euler ? vNow : a.vel0[i]) + span * acc;
      x = x + a.dt * vcast<double>(vNow) + (0.5 * a.dt * a.dt) * vcast<double>(acc);
      a.vel0[i] = vNow;
    }
    return finishStep(a, i, fluid, x, v, r);
  }
};

// Velocity Verlet (kick-drift-kick; sph.integrator: velocity_verlet), one evaluation of the rates per step. The
// first kick and the drift, with the rates of the state now (n): v(n+1/2) = v + dt/2 a and rho(n+1/2) = rho + dt/2
// drho are kept (vel0, rho0); x' = x + dt v(n+1/2); the rates of the next step are evaluated at x' with the velocity
// and density predicted a whole step, v + dt a and rho + dt drho (and their pressure). Returns the squared
// displacement since the last cell sort.
template <class R>
struct KickDrift {
  StepArgs<R> a;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    const R half = R(0.5 * a.dt);
    const R r0 = a.rho[i], dr = a.drho[i];
    R rHalf = r0 + half * dr, r = rHalf + half * dr;
    if (a.kind[i] == kFluid) {
      const Vec3<R> acc = a.acc[i];
      Vec3<R> vHalf = a.vel[i] + half * acc;
      Vec3d x = a.pos[i] + a.dt * vcast<double>(vHalf);
      if (a.mirror.any) a.mirror.keepInside(x, vHalf);
      a.vel0[i] = vHalf;
      a.vel[i] = vHalf + half * acc;
      a.pos[i] = x;
    } else if (a.extrapolatedBoundary) {
      return norm2(a.pos[i] - a.ref[i]);
    } else {
      rHalf = rHalf < a.boundaryFloor ? a.boundaryFloor : rHalf;
      r = r < a.boundaryFloor ? a.boundaryFloor : r;
    }
    a.rho0[i] = rHalf;
    a.rho[i] = r;
    a.p[i] = a.eos.pressure(r);
    return norm2(a.pos[i] - a.ref[i]);
  }
};

// The second kick, with the rates at x': v' = v(n+1/2) + dt/2 a', rho' = rho(n+1/2) + dt/2 drho'; finished by
// finishStep. Positions do not move here: the step's displacement is KickDrift's (no reduction).
template <class R>
struct Kick {
  StepArgs<R> a;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const R half = R(0.5 * a.dt);
    const bool fluid = a.kind[i] == kFluid;
    const R r = a.rho0[i] + half * a.drho[i];
    Vec3<R> v = a.vel[i];
    if (fluid) v = a.vel0[i] + half * a.acc[i];
    (void)finishStep(a, i, fluid, a.pos[i], v, r);
  }
};

// Each particle's inverseStep (SphPhysics.h): their maximum sets the next step, in one reduction.
template <class R>
struct InverseStep {
  const Vec3<R>* acc;
  const R* visc;
  const std::int32_t* kind;
  double h, c0;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    return inverseStep(h, c0, double(norm2(acc[i])), double(visc[i]), kind[i] == kFluid);
  }
};

}  // namespace pflow::compute::sph::kernels
