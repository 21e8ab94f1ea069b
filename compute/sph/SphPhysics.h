// Weakly compressible SPH, the physics: smoothing kernels, the equation of state and the pairwise terms of
// the momentum and continuity equations, as stateless PFLOW_HOSTDEVICE functions over plain parameter
// structs. Every equation, its constants and its source are in docs/sph.md; the engine's kernels
// (SphKernels.h) only loop over pairs and call these, on the CPU and on the GPU alike.
#pragma once
#include <cmath>
#include <cstdint>

#include "compute/core/FastMath.h"
#include "compute/core/VectorMath.h"

namespace pflow::compute::sph {

// Smoothing kernels with support 2h (q = r/h in [0, 2]).
enum class KernelKind : std::int32_t { kWendlandC2 = 0, kCubicSpline = 1 };

// A kernel of one kind in one dimension (2 or 3) at one smoothing length, with its constants folded.
// w(r): W(r, h). f(r): (1/r) dW/dr, so that grad_a W_ab = f(r_ab) * (x_a - x_b).
template <class R>
struct Kernel {
  KernelKind kind = KernelKind::kWendlandC2;
  R h = R(1), invH = R(1);
  R alpha = R(0);  // normalisation alpha_D

  static Kernel make(KernelKind kind, int dimension, double h) {
    constexpr double pi = 3.14159265358979323846;
    Kernel k;
    k.kind = kind;
    k.h = R(h);
    k.invH = R(1.0 / h);
    if (kind == KernelKind::kWendlandC2)  // Wendland (1995): 7/(4 pi h^2) in 2D, 21/(16 pi h^3) in 3D
      k.alpha = R(dimension == 2 ? 7.0 / (4.0 * pi * h * h) : 21.0 / (16.0 * pi * h * h * h));
    else  // Monaghan & Lattanzio (1985): 10/(7 pi h^2) in 2D, 1/(pi h^3) in 3D
      k.alpha = R(dimension == 2 ? 10.0 / (7.0 * pi * h * h) : 1.0 / (pi * h * h * h));
    return k;
  }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R support() const { return R(2) * h; }

  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R w(R r) const {
    const R q = r * invH;
    if (q >= R(2)) return R(0);
    if (kind == KernelKind::kWendlandC2) {
      const R a = R(1) - R(0.5) * q;
      const R a2 = a * a;
      return alpha * a2 * a2 * (R(2) * q + R(1));
    }
    if (q < R(1)) return alpha * (R(1) - R(1.5) * q * q + R(0.75) * q * q * q);
    const R b = R(2) - q;
    return alpha * R(0.25) * b * b * b;
  }
  // (1/r) dW/dr: finite at r = 0 (where the gradient itself is zero).
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R f(R r) const {
    const R q = r * invH;
    if (q >= R(2)) return R(0);
    const R c = alpha * invH * invH;
    if (kind == KernelKind::kWendlandC2) {  // dW/dq = -5 q (1 - q/2)^3
      const R a = R(1) - R(0.5) * q;
      return R(-5) * c * a * a * a;
    }
    if (q < R(1)) return c * (R(-3) + R(2.25) * q);  // dW/dq = -3q + 9/4 q^2
    const R b = R(2) - q;
    return R(-0.75) * c * b * b / q;  // dW/dq = -3/4 (2 - q)^2
  }
};

// Tait (Cole) equation of state p = B ((rho/rho0)^gamma - 1), B = c0^2 rho0 / gamma.
template <class R>
struct Tait {
  R rho0 = R(1000), c0 = R(1), gamma = R(7), b = R(1000.0 / 7.0);
  static Tait make(double rho0, double c0, double gamma) {
    return {R(rho0), R(c0), R(gamma), R(c0 * c0 * rho0 / gamma)};
  }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R pressure(R rho) const {
    const R x = rho / rho0;
    if (gamma == R(7)) {  // the usual exponent, without pow
      const R x2 = x * x, x3 = x2 * x;
      return b * (x3 * x3 * x - R(1));
    }
    return b * (std::pow(x, gamma) - R(1));
  }
  // The density at which the pressure is p (the inverse).
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R density(R p) const { return rho0 * std::pow(R(1) + p / b, R(1) / gamma); }
  // Local speed of sound c = sqrt(dp/drho) = c0 (rho/rho0)^((gamma - 1)/2).
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R soundSpeed(R rho) const {
    return c0 * std::pow(rho / rho0, R(0.5) * (gamma - R(1)));
  }
};

// Parameters of the pair terms, the same for every pair of a run.
template <class R>
struct PairParams {
  R alpha = R(0);    // Monaghan artificial viscosity coefficient (0: none)
  R nu = R(0);       // laminar kinematic viscosity [m^2/s] (0: none), Morris et al. (1997) / Lo & Shao (2002) form
  R delta = R(0);    // density diffusion coefficient (Molteni & Colagrossi 2009; 0: none)
  R eta2 = R(0);     // 0.01 h^2: keeps the 1/r^2 terms finite
  R h = R(1), c0 = R(1);
  // Fourtakas et al. (2019) hydrostatic correction of the density diffusion: the diffusion acts on the
  // departure from the hydrostatic density difference rho0 g.(x_b - x_a) / c0^2 (linearised Tait), which is
  // otherwise smoothed away near the free surface and the walls. g along the run's gravity.
  bool hydrostatic = true;
  Vec3<R> gOverC2{R(0), R(0), R(0)};  // gravity / c0^2 [1/m]
  R rho0 = R(1000);
};

// What particle b adds to a's rates.
template <class R>
struct PairRates {
  Vec3<R> acceleration;  // dv_a/dt contribution [m/s^2]
  R densityRate;         // drho_a/dt contribution [kg/m^3/s]
  R viscousRate;         // |h v_ab.x_ab / (r^2 + eta^2)| [1/s], for the viscous time-step limit
};

// What the pair adds to b's rates (the pairs once, SphKernels.h: each pair evaluated by one of its particles, the
// other's share added to it by an atomic add). The viscous rate is the pair's own, the same from either side.
template <class R>
struct PairReaction {
  Vec3<R> acceleration;  // dv_b/dt contribution [m/s^2]
  R densityRate;         // drho_b/dt contribution [kg/m^3/s]
};

// One side of a pair as the pair terms use it: the density, p/rho^2, the mass and m/rho (a's mass and m/rho only
// where b's reaction is formed). The rates pass packs them once per particle (SphKernels.h, PackRates), not once per pair.
template <class R>
struct PairSide {
  R rho, pOverRho2, m, mOverRho;
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE static PairSide of(R rho, R p, R m) { return {rho, p / (rho * rho), m, m / rho}; }
};

// One pair's terms (docs/sph.md, equations 4-8). xab = x_a - x_b, vab = v_a - v_b, fab = (1/r) dW/dr at
// r = |xab| (so grad_a W_ab = fab xab). `diffuse`: both are fluid (density diffusion acts between fluid
// particles only; walls are driven by continuity alone). Two divisions per pair: 1/(r^2 + eta^2) and, where
// the artificial viscosity acts, the mean density (float on the GPU: the approximate quotient, FastMath.h).
// kReaction: b's share too, into *toB, from the same factors: every term is antisymmetric in (a, b) but for the
// partner's mass, so b's is a's with m_b -> m_a (m_b/rho_b -> m_a/rho_a) and the sign of the acceleration and the
// diffusion flipped (the continuity term keeps its sign: v_ab and grad W both flip).
template <bool kReaction = false, class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE PairRates<R> pairRates(const PairParams<R>& p, Vec3<R> xab, Vec3<R> vab, R r2, R fab,
                                                          const PairSide<R>& a, const PairSide<R>& b, R cA, R cB, bool diffuse,
                                                          PairReaction<R>* toB = nullptr) {
  PairRates<R> out;
  const Vec3<R> gradW = fab * xab;
  const R vdotx = dot(vab, xab);
  const R invDenom = divFast(R(1), r2 + p.eta2);
  // Momentum: pressure (symmetric form, conserves linear momentum) and Monaghan's artificial viscosity.
  R pi = R(0);
  const R mu = p.h * vdotx * invDenom;
  if (vdotx < R(0) && p.alpha > R(0)) pi = divFast(-p.alpha * (cA + cB) * mu, a.rho + b.rho);
  const R s = a.pOverRho2 + b.pOverRho2 + pi;
  const R coef = -b.m * s;
  out.acceleration = coef * gradW;
  if constexpr (kReaction) toB->acceleration = (a.m * s) * gradW;
  // Laminar viscosity: m_b 4 nu (x_ab . grad W) / ((rho_a + rho_b)(r^2 + eta^2)) v_ab.
  if (p.nu > R(0)) {  // one quotient could serve both sides: tried, it changed the float pass's spills; not timed, not kept
    out.acceleration += divFast(b.m * R(4) * p.nu * fab * r2 * invDenom, a.rho + b.rho) * vab;
    if constexpr (kReaction) toB->acceleration -= divFast(a.m * R(4) * p.nu * fab * r2 * invDenom, a.rho + b.rho) * vab;
  }
  // Continuity: m_b v_ab . grad W.
  out.densityRate = b.m * fab * vdotx;
  if constexpr (kReaction) toB->densityRate = a.m * fab * vdotx;
  // Density diffusion: 2 delta h c0 sum (rho_b - rho_a - hydrostatic) (x_ba . grad W)/(r^2 + eta^2) m_b/rho_b.
  if (diffuse && p.delta > R(0)) {
    R drho = b.rho - a.rho;
    if (p.hydrostatic) drho -= p.rho0 * dot(p.gOverC2, -xab);  // rho0 g.(x_b - x_a) / c0^2
    const R d = R(2) * p.delta * p.h * p.c0 * drho * (-fab * r2) * invDenom;
    out.densityRate += d * b.mOverRho;
    if constexpr (kReaction) toB->densityRate -= d * a.mOverRho;
  }
  out.viscousRate = std::fabs(mu);
  return out;
}

// The same from the plain values of both particles (tests, the mirror images).
template <class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE PairRates<R> pairRates(const PairParams<R>& p, Vec3<R> xab, Vec3<R> vab, R r2, R fab,
                                                          R rhoA, R rhoB, R pA, R pB, R mB, R cA, R cB, bool diffuse) {
  return pairRates(p, xab, vab, r2, fab, PairSide<R>::of(rhoA, pA, R(0)), PairSide<R>::of(rhoB, pB, mB), cA, cB, diffuse);
}

// Mirror walls (sph.boundary: mirror; docs/sph.md, "Mirror walls"): the tank's flat walls, normal to the axes.
// A fluid particle b within the kernel's support of a wall is seen through it as its image: the position
// reflected, the velocity with its normal part reversed (free slip) in the continuity equation and in the
// momentum equation's pressure and viscous terms, or wholly reversed (no-slip) in the momentum equation, the
// density b's, the pressure b's plus the hydrostatic difference rho_b g.(x_b' - x_b). Near a corner b has an image
// across each wall it is near and one across both (three walls: seven). The images act through the pair terms
// without density diffusion (no flux across a wall).
struct MirrorWalls {
  bool lo[3] = {false, false, false}, hi[3] = {false, false, false};  // which walls are mirrors
  double loAt[3] = {0, 0, 0}, hiAt[3] = {0, 0, 0};                   // where [m]
  double reach = 0;                                                   // the kernel's support [m]
  bool noSlip = true;
  bool any = false;

  // Per axis, the wall x is within reach of: bits 0-2 the low wall of axis 0-2, bits 3-5 the high wall (the
  // nearer one when both are, in a tank narrower than two supports).
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE int near(const Vec3d& x) const {
    int mask = 0;
    for (int a = 0; a < 3; ++a) {
      const double c = (&x.x)[a];
      const double dLo = c - loAt[a], dHi = hiAt[a] - c;
      const bool nLo = lo[a] && dLo < reach, nHi = hi[a] && dHi < reach;
      if (nLo && (!nHi || dLo <= dHi)) mask |= 1 << a;
      else if (nHi) mask |= 8 << a;
    }
    return mask;
  }
  // x reflected across the walls of `mask` (near()'s bits).
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3d reflect(Vec3d x, int mask) const {
    for (int a = 0; a < 3; ++a) {
      double& c = (&x.x)[a];
      if (mask & (1 << a)) c = 2 * loAt[a] - c;
      else if (mask & (8 << a)) c = 2 * hiAt[a] - c;
    }
    return x;
  }
  template <class R>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<R> imageVelocity(Vec3<R> v, int mask, bool reversed) const {
    if (reversed) {  // no-slip: reversed once per wall
      int walls = 0;
      for (int a = 0; a < 3; ++a) walls += (mask >> a & 1) | (mask >> (a + 3) & 1);
      return walls % 2 ? Vec3<R>{-v.x, -v.y, -v.z} : v;
    }
    for (int a = 0; a < 3; ++a)
      if (mask & (9 << a)) (&v.x)[a] = -(&v.x)[a];
    return v;
  }
  // A particle that crossed a mirror wall (a step too long for the repulsion) is put back: position reflected,
  // normal velocity reversed. Returns true if it did.
  template <class R>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool keepInside(Vec3d& x, Vec3<R>& v) const {
    bool moved = false;
    for (int a = 0; a < 3; ++a) {
      double& c = (&x.x)[a];
      R& u = (&v.x)[a];
      if (lo[a] && c < loAt[a]) {
        c = 2 * loAt[a] - c;
        u = u < R(0) ? -u : u;
        moved = true;
      } else if (hi[a] && c > hiAt[a]) {
        c = 2 * hiAt[a] - c;
        u = u > R(0) ? -u : u;
        moved = true;
      }
    }
    return moved;
  }
};

// The reciprocal of the step one particle allows before the CFL factor (docs/sph.md, equation 10): the larger of
// sqrt(|a| / h) (the force limit; fluid only: walls do not move) and (c0 + h visc) / h (the acoustic-viscous
// limit, visc the particle's largest viscous rate). Its maximum over the particles is one reduction.
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE double inverseStep(double h, double c0, double accel2, double viscous, bool fluid) {
  const double acoustic = (c0 + h * viscous) / h;
  if (!fluid) return acoustic;
  const double force = std::sqrt(std::sqrt(accel2) / h);
  return force > acoustic ? force : acoustic;
}

// The step a run can take now: CFL over the largest inverseStep, and with laminar viscosity at most 0.125 h^2/nu
// (Morris et al. 1997; not divided by the CFL).
inline double stableDt(double cfl, double h, double nu, double maxInverseStep) {
  double dt = cfl / maxInverseStep;
  if (nu > 0) dt = std::fmin(dt, 0.125 * h * h / nu);
  return dt;
}

}  // namespace pflow::compute::sph
