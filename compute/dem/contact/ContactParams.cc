#include "compute/dem/contact/ContactParams.h"

#include <cmath>
#include <map>
#include <mutex>
#include <numbers>

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

double linearSpringDampingCoeff(double e) {
  const double l = std::log(e);
  return -2.0 * std::sqrt(5.0 / 6.0) * l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi);
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
        }
      }
      p.dampingCoeff = dampingCoeffForRestitution(p.restitution);
      p.tangentialRatio = std::sqrt(4.0 * p.effShear / p.effYoung);
      table[a * nm + b] = p;
      table[b * nm + a] = p;
    }
  }
  return table;
}

}  // namespace pflow::compute
