#include "compute/dem/contact/ContactParams.h"

#include <cmath>
#include <array>
#include <map>
#include <mutex>
#include <numbers>

#include "compute/dem/contact/ContactModels.h"
#include "compute/sim/RunConfig.h"

namespace pflow::compute {

namespace {
double shearModulus(const MaterialConfig& m) { return m.youngsModulus / (2.0 * (1.0 + m.poissonRatio)); }
}  // namespace

double restitutionForDampingCoeff(double c) {
  // Dimensionless normal impact: x'' = -max(0, x^{3/2} + g x^{1/4} x'), x(0) = 0, x'(0) = 1, with
  // g = c sqrt(3/2) (from S_n = 2 E* sqrt(R*) x^{1/2} over k = 4/3 E* sqrt(R*)). The contact ends
  // when x returns to 0; e = -x'(end). Classical RK4 with a step far below the contact time (~3.2).
  if (c <= 0) return 1.0;
  const double g = c * std::sqrt(1.5);
  auto acc = [g](double x, double v) {
    if (x <= 0) return 0.0;
    const double f = std::pow(x, 1.5) + g * std::pow(x, 0.25) * v;
    return f > 0 ? -f : 0.0;
  };
  double x = 0, v = 1;
  const double h = 5e-4;
  for (int it = 0; it < 10'000'000; ++it) {
    const double k1x = v, k1v = acc(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = acc(x + h * k3x, v + h * k3v);
    const double xn = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
    const double vn = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    if (xn <= 0 && vn < 0) {
      // Linear interpolation to the crossing; the force there is zero, so v is nearly constant.
      const double s = x / (x - xn);
      return -(v + s * (vn - v));
    }
    x = xn;
    v = vn;
  }
  return 0.0;
}

double dampingCoeffForRestitution(double e) {
  if (e >= 1.0) return 0.0;
  // The map is a pure function of e: solve each value once per process.
  static std::mutex mutex;
  static std::map<double, double> cache;
  {
    std::lock_guard lock(mutex);
    if (auto it = cache.find(e); it != cache.end()) return it->second;
  }
  // e(c) decreases monotonically; bracket then bisect.
  double lo = 0.0, hi = 1.0;
  while (restitutionForDampingCoeff(hi) > e && hi < 1e6) hi *= 2;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (restitutionForDampingCoeff(mid) > e ? lo : hi) = mid;
    if (hi - lo < 1e-10 * hi) break;
  }
  const double c = 0.5 * (lo + hi);
  std::lock_guard lock(mutex);
  cache[e] = c;
  return c;
}

double restitutionOfStep(double c, const double poly[3], double h, double phase) {
  // Units: k = 4/3 E* sqrt(R*) = 1 with R* = 1 (E* = 3/4), m* = 1, impact speed 1; the contact lasts about 3.2.
  ContactParams p;
  p.effYoung = 0.75;
  p.dampingCoeff = c;
  for (int k = 0; k < 3; ++k) p.dashpotStep[k] = float(poly[k]);
  auto accel = [&](double x, double v) {
    if (x <= 0) return 0.0;
    double dampN, touch;
    return -contact::normal::hertzNormal(p, x, std::sqrt(x), v, 1.0, h, dampN, touch);
  };
  // pflow's velocity Verlet: the force at the new overlap with the half-step velocity.
  double x = -phase * h, v = 1, a = 0;
  bool touched = false;
  for (long n = 0; n < 100'000'000; ++n) {
    const double vh = v + 0.5 * h * a;
    x += h * vh;
    a = accel(x, vh);
    v = vh + 0.5 * h * a;
    touched |= x > 0;
    if (touched && x <= 0) return -v;
  }
  return 0.0;
}

void calibrateDashpotForStep(double e, double poly[3]) {
  poly[0] = poly[1] = poly[2] = 0;
  if (e >= 1.0 || e < 0.1) return;
  static std::mutex mutex;
  static std::map<double, std::array<double, 3>> cache;
  {
    std::lock_guard lock(mutex);
    if (auto it = cache.find(e); it != cache.end()) {
      for (int k = 0; k < 3; ++k) poly[k] = it->second[k];
      return;
    }
  }
  const double c = dampingCoeffForRestitution(e);
  constexpr double kSteps[] = {0.02, 0.05, 0.08, 0.12, 0.16, 0.2, 0.24, 0.28, 0.32, 0.36};
  constexpr int kN = std::size(kSteps), kPhases = 8;
  auto residuals = [&](const std::array<double, 3>& a) {
    std::array<double, kN> r{};
    for (int i = 0; i < kN; ++i) {
      double sum = 0;
      for (int k = 0; k < kPhases; ++k) sum += restitutionOfStep(c, a.data(), kSteps[i], (k + 0.5) / kPhases) / e - 1;
      r[i] = sum / kPhases;
    }
    return r;
  };
  // Gauss-Newton on the three coefficients (the residuals are smooth in them), Jacobian by differences.
  std::array<double, 3> a{0, 0, 0};
  for (int it = 0; it < 8; ++it) {
    const auto r = residuals(a);
    double jac[kN][3];
    for (int j = 0; j < 3; ++j) {
      std::array<double, 3> b = a;
      b[j] += 1e-4;
      const auto rb = residuals(b);
      for (int i = 0; i < kN; ++i) jac[i][j] = (rb[i] - r[i]) / 1e-4;
    }
    double m[3][4] = {};
    for (int i = 0; i < kN; ++i)
      for (int p = 0; p < 3; ++p) {
        m[p][3] -= jac[i][p] * r[i];
        for (int q = 0; q < 3; ++q) m[p][q] += jac[i][p] * jac[i][q];
      }
    for (int p = 0; p < 3; ++p) {  // Gauss-Jordan with partial pivoting
      int piv = p;
      for (int q = p + 1; q < 3; ++q)
        if (std::fabs(m[q][p]) > std::fabs(m[piv][p])) piv = q;
      for (int k = 0; k < 4; ++k) std::swap(m[p][k], m[piv][k]);
      if (m[p][p] == 0) return;
      for (int q = 0; q < 3; ++q)
        if (q != p) {
          const double f = m[q][p] / m[p][p];
          for (int k = 0; k < 4; ++k) m[q][k] -= f * m[p][k];
        }
    }
    double step = 0;
    for (int p = 0; p < 3; ++p) {
      const double d = m[p][3] / m[p][p];
      a[p] += d;
      step = std::max(step, std::fabs(d));
    }
    if (step < 1e-7) break;
  }
  for (int k = 0; k < 3; ++k) poly[k] = a[k];
  std::lock_guard lock(mutex);
  cache[e] = a;
}

double linearSpringDampingCoeff(double e) {
  const double l = std::log(e);
  return -2.0 * std::sqrt(5.0 / 6.0) * l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi);
}

double contactEnergy(const ContactParams& p, double effRadius, double overlap) {
  if (overlap <= 0) return 0.0;
  const double hertz = contact::normal::hertzEnergy(p.effYoung, effRadius, overlap);
  if (p.cohesion == contact::cohesion::kJkr)
    return contact::cohesion::jkrEnergy(p.effYoung, p.jkrB, effRadius, contact::cohesion::jkrRootRadius(p.jkrB, effRadius, overlap));
  if (p.cohesion == contact::cohesion::kConstant)
    return hertz - contact::cohesion::constantAdhesion(p.effYoung, p.jkrB, effRadius) * overlap;
  return hertz;
}

double adhesionWellDepth(const ContactParams& p, double effRadius) {
  if (p.cohesion == contact::cohesion::kJkr)
    return -contact::cohesion::jkrEnergy(p.effYoung, p.jkrB, effRadius, std::cbrt(1.5 * p.jkrB * effRadius));
  if (p.cohesion == contact::cohesion::kConstant) {
    const double f0 = contact::cohesion::constantAdhesion(p.effYoung, p.jkrB, effRadius);
    const double d = std::cbrt(std::pow(0.75 * f0 / (p.effYoung * std::sqrt(effRadius)), 2));
    return 0.6 * f0 * d;
  }
  return 0.0;
}

void setCohesion(ContactParams& p, int model, double workOfAdhesion) {
  p.cohesion = workOfAdhesion > 0 ? model : 0;
  p.workOfAdhesion = p.cohesion ? workOfAdhesion : 0;
  const double pg = std::numbers::pi * p.workOfAdhesion / p.effYoung;
  p.jkrB = std::sqrt(2.0 * pg);
  p.jkrBreak = 0.75 * std::cbrt(pg * pg);
}

std::vector<ContactParams> buildContactTable(const std::vector<MaterialConfig>& materials,
                                             const std::vector<MaterialPairConfig>& pairs) {
  const std::size_t nm = materials.size();
  std::vector<ContactParams> table(nm * nm);
  for (std::size_t a = 0; a < nm; ++a) {
    for (std::size_t b = a; b < nm; ++b) {
      const auto& ma = materials[a];
      const auto& mb = materials[b];
      ContactParams p;
      p.effYoung = 1.0 / ((1 - ma.poissonRatio * ma.poissonRatio) / ma.youngsModulus +
                          (1 - mb.poissonRatio * mb.poissonRatio) / mb.youngsModulus);
      p.effShear = 1.0 / ((2 - ma.poissonRatio) / shearModulus(ma) + (2 - mb.poissonRatio) / shearModulus(mb));
      p.restitution = 0.5 * (ma.restitution + mb.restitution);
      p.friction = 0.5 * (ma.friction + mb.friction);
      p.rollingFriction = 0.5 * (ma.rollingFriction + mb.rollingFriction);
      for (const auto& o : pairs) {
        if ((std::size_t(o.a) == a && std::size_t(o.b) == b) || (std::size_t(o.a) == b && std::size_t(o.b) == a)) {
          if (o.restitution) p.restitution = *o.restitution;
          if (o.friction) p.friction = *o.friction;
          if (o.rollingFriction) p.rollingFriction = *o.rollingFriction;
          setCohesion(p, int(o.cohesion), o.workOfAdhesion);
        }
      }
      p.dampingCoeff = dampingCoeffForRestitution(p.restitution);
      double step[3];
      calibrateDashpotForStep(p.restitution, step);
      for (int k = 0; k < 3; ++k) p.dashpotStep[k] = float(step[k]);
      p.tangentialRatio = std::sqrt(4.0 * p.effShear / p.effYoung);
      p.fixedSide = (ma.fixed ? 1 : 0) | (mb.fixed ? 2 : 0);
      table[a * nm + b] = p;
      p.fixedSide = (mb.fixed ? 1 : 0) | (ma.fixed ? 2 : 0);
      table[b * nm + a] = p;
    }
  }
  return table;
}

}  // namespace pflow::compute
