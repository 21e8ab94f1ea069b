#include "frontend/generators/SizeDistribution.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <sstream>

namespace pflow::frontend {
namespace {

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

bool positiveFinite(double v) { return std::isfinite(v) && v > 0; }

// Standard normal CDF.
double phiCdf(double x) { return 0.5 * std::erfc(-x / std::numbers::sqrt2); }

// Smallest share of a normal (or log-normal) law that [min, max] may keep: rejection sampling then needs
// at most 1000 draws per radius on average.
constexpr double kMinKeptMass = 1e-3;

// Composite Simpson rule of f over [a, b]; f smooth, n even.
template <class F>
double simpson(F f, double a, double b, int n = 4096) {
  if (!(b > a)) return 0;
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += f(a + i * h) * ((i % 2) ? 4.0 : 2.0);
  return s * h / 3.0;
}

}  // namespace

SizeDistribution SizeDistribution::single(double radius) {
  SizeDistribution d;
  d.m_kind = Kind::kSingle;
  d.m_a = radius;
  d.m_min = d.m_max = radius;
  return d;
}

SizeDistribution SizeDistribution::uniform(double min, double max) {
  SizeDistribution d;
  d.m_kind = Kind::kUniform;
  d.m_min = min;
  d.m_max = max;
  return d;
}

SizeDistribution SizeDistribution::normal(double mean, double std, double min, double max) {
  SizeDistribution d;
  d.m_kind = Kind::kNormal;
  d.m_a = mean;
  d.m_b = std;
  d.m_min = min;
  d.m_max = max;
  return d;
}

SizeDistribution SizeDistribution::logNormal(double median, double geometricStd, double min, double max) {
  SizeDistribution d;
  d.m_kind = Kind::kLogNormal;
  d.m_a = median;
  d.m_b = geometricStd;
  d.m_min = min;
  d.m_max = max;
  return d;
}

SizeDistribution SizeDistribution::discrete(std::vector<double> radii, std::vector<double> fractions, Basis basis) {
  SizeDistribution d;
  d.m_kind = Kind::kDiscrete;
  d.m_radii = std::move(radii);
  d.m_fractions = std::move(fractions);
  d.m_basis = basis;
  // Number fractions and their running sum; meaningful only when validate() is empty.
  if (d.m_radii.size() == d.m_fractions.size() && !d.m_radii.empty()) {
    d.m_numberFractions.resize(d.m_radii.size());
    double total = 0;
    for (std::size_t i = 0; i < d.m_radii.size(); ++i) {
      const double r = d.m_radii[i];
      d.m_numberFractions[i] = basis == Basis::kNumber ? d.m_fractions[i] : d.m_fractions[i] / (r * r * r);
      total += d.m_numberFractions[i];
    }
    double running = 0;
    for (std::size_t i = 0; i < d.m_radii.size(); ++i) {
      d.m_numberFractions[i] = total > 0 ? d.m_numberFractions[i] / total : 0;
      running += d.m_numberFractions[i];
      d.m_cumulative.push_back(running);
    }
    // The last radius with a non-zero share ends the table at exactly 1, so every u in [0, 1) finds a radius.
    for (std::size_t i = d.m_radii.size(); i-- > 0;) {
      if (d.m_numberFractions[i] > 0) {
        for (std::size_t j = i; j < d.m_radii.size(); ++j) d.m_cumulative[j] = 1.0;
        break;
      }
    }
    d.m_min = *std::min_element(d.m_radii.begin(), d.m_radii.end());
    d.m_max = *std::max_element(d.m_radii.begin(), d.m_radii.end());
  }
  return d;
}

ErrorList SizeDistribution::validate(const std::string& path) const {
  ErrorList e;
  auto bounds = [&] {
    bool ok = true;
    if (!positiveFinite(m_min)) e.add(path + ".min", num(m_min) + " must be > 0 and finite"), ok = false;
    if (!positiveFinite(m_max)) e.add(path + ".max", num(m_max) + " must be > 0 and finite"), ok = false;
    if (ok && m_min > m_max) e.add(path + ".min", num(m_min) + " must be <= max " + num(m_max)), ok = false;
    return ok;
  };
  switch (m_kind) {
    case Kind::kSingle:
      if (!positiveFinite(m_a)) e.add(path + ".radius", num(m_a) + " must be > 0 and finite");
      break;
    case Kind::kUniform:
      bounds();
      break;
    case Kind::kNormal: {
      const bool ok = bounds();
      const bool meanOk = positiveFinite(m_a), stdOk = positiveFinite(m_b);
      if (!meanOk) e.add(path + ".mean", num(m_a) + " must be > 0 and finite");
      if (!stdOk) e.add(path + ".std", num(m_b) + " must be > 0 and finite");
      if (ok && meanOk && stdOk) {
        const double kept = phiCdf((m_max - m_a) / m_b) - phiCdf((m_min - m_a) / m_b);
        if (!(kept >= kMinKeptMass)) {
          e.add(path, "[min, max] = [" + num(m_min) + ", " + num(m_max) + "] keeps only " + num(kept) + " of the normal law (mean " + num(m_a) +
                          ", std " + num(m_b) + "); it must keep at least " + num(kMinKeptMass));
        }
      }
      break;
    }
    case Kind::kLogNormal: {
      const bool ok = bounds();
      const bool medianOk = positiveFinite(m_a);
      const bool gsdOk = std::isfinite(m_b) && m_b > 1;
      if (!medianOk) e.add(path + ".median", num(m_a) + " must be > 0 and finite");
      if (!gsdOk) e.add(path + ".geometric_std", num(m_b) + " must be > 1 and finite (1 is a single radius)");
      if (ok && medianOk && gsdOk) {
        const double s = std::log(m_b), mu = std::log(m_a);
        const double kept = phiCdf((std::log(m_max) - mu) / s) - phiCdf((std::log(m_min) - mu) / s);
        if (!(kept >= kMinKeptMass)) {
          e.add(path, "[min, max] = [" + num(m_min) + ", " + num(m_max) + "] keeps only " + num(kept) + " of the log-normal law (median " +
                          num(m_a) + ", geometric std " + num(m_b) + "); it must keep at least " + num(kMinKeptMass));
        }
      }
      break;
    }
    case Kind::kDiscrete: {
      if (m_radii.empty()) e.add(path + ".radii", "must list at least one radius");
      if (m_radii.size() != m_fractions.size()) {
        e.add(path + ".fractions", "has " + std::to_string(m_fractions.size()) + " entries; it must have one per radius (" +
                                       std::to_string(m_radii.size()) + ")");
      }
      for (std::size_t i = 0; i < m_radii.size(); ++i) {
        if (!positiveFinite(m_radii[i])) e.add(path + ".radii[" + std::to_string(i) + "]", num(m_radii[i]) + " must be > 0 and finite");
      }
      bool fractionsOk = true;
      for (std::size_t i = 0; i < m_fractions.size(); ++i) {
        if (!std::isfinite(m_fractions[i]) || m_fractions[i] < 0 || m_fractions[i] > 1) {
          e.add(path + ".fractions[" + std::to_string(i) + "]", num(m_fractions[i]) + " must be in [0, 1]");
          fractionsOk = false;
        }
      }
      if (fractionsOk && !m_fractions.empty()) {
        const double sum = std::accumulate(m_fractions.begin(), m_fractions.end(), 0.0);
        if (std::fabs(sum - 1.0) > 1e-6) {
          e.add(path + ".fractions", std::string("sum to ") + num(sum) + "; fractions by " + (m_basis == Basis::kNumber ? "number" : "volume") +
                                         " must sum to 1 within 1e-6");
        }
      }
      break;
    }
  }
  return e;
}

double SizeDistribution::sample(Random& rng) const {
  switch (m_kind) {
    case Kind::kSingle:
      return m_a;
    case Kind::kUniform:
      return m_min + (m_max - m_min) * rng.uniform();  // never above max: uniform() < 1
    case Kind::kNormal:
      for (;;) {
        const double r = m_a + m_b * rng.normal();
        if (r >= m_min && r <= m_max) return r;
      }
    case Kind::kLogNormal: {
      const double s = std::log(m_b);
      for (;;) {
        const double r = m_a * std::exp(s * rng.normal());
        if (r >= m_min && r <= m_max) return r;
      }
    }
    case Kind::kDiscrete: {
      const double u = rng.uniform();
      const auto it = std::upper_bound(m_cumulative.begin(), m_cumulative.end(), u);
      return m_radii[static_cast<std::size_t>(it - m_cumulative.begin())];
    }
  }
  return m_a;
}

double SizeDistribution::minRadius() const { return m_kind == Kind::kSingle ? m_a : m_min; }
double SizeDistribution::maxRadius() const { return m_kind == Kind::kSingle ? m_a : m_max; }

double SizeDistribution::moment(int p) const {
  switch (m_kind) {
    case Kind::kSingle:
      return std::pow(m_a, p);
    case Kind::kUniform:
      if (m_max == m_min) return std::pow(m_min, p);
      return (std::pow(m_max, p + 1) - std::pow(m_min, p + 1)) / ((p + 1) * (m_max - m_min));
    case Kind::kNormal: {
      auto w = [&](double r) { return std::exp(-0.5 * ((r - m_a) / m_b) * ((r - m_a) / m_b)); };
      const double mass = simpson(w, m_min, m_max);
      if (!(mass > 0)) return std::pow(m_min, p);
      return simpson([&](double r) { return w(r) * std::pow(r, p); }, m_min, m_max) / mass;
    }
    case Kind::kLogNormal: {
      const double s = std::log(m_b), mu = std::log(m_a);
      auto w = [&](double u) { return std::exp(-0.5 * ((u - mu) / s) * ((u - mu) / s)); };
      const double lo = std::log(m_min), hi = std::log(m_max);
      const double mass = simpson(w, lo, hi);
      if (!(mass > 0)) return std::pow(m_min, p);
      return simpson([&](double u) { return w(u) * std::exp(p * u); }, lo, hi) / mass;
    }
    case Kind::kDiscrete: {
      double m = 0;
      for (std::size_t i = 0; i < m_radii.size() && i < m_numberFractions.size(); ++i) m += m_numberFractions[i] * std::pow(m_radii[i], p);
      return m;
    }
  }
  return 0;
}

double SizeDistribution::meanRadius() const { return moment(1); }
double SizeDistribution::meanVolume() const { return 4.0 / 3.0 * std::numbers::pi * moment(3); }

}  // namespace pflow::frontend
