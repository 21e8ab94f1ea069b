#include "compute/dem/TimeStep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

namespace pflow::compute {
namespace {

// Above this fraction of the Rayleigh time the explicit step is known to misbehave (physics-reference.md).
constexpr double kMaxSafeRayleighFraction = 0.4;
// Fewer steps than this per Hertz contact resolve the force pulse poorly.
constexpr double kMinStepsPerContact = 20.0;

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

std::string materialLabel(const RunConfig& c, std::size_t m) {
  const std::string name = c.materials[m].name;
  return name.empty() ? "materials[" + std::to_string(m) + "]" : "'" + name + "'";
}

}  // namespace

double rayleighTime(double radius, double density, double youngsModulus, double poissonRatio) {
  const double shearModulus = youngsModulus / (2.0 * (1.0 + poissonRatio));
  return std::numbers::pi * radius * std::sqrt(density / shearModulus) / (0.1631 * poissonRatio + 0.8766);
}

double hertzContactTime(double effRadius, double effMass, double effModulus, double approachSpeed) {
  return 2.868 * std::pow(effMass * effMass / (effRadius * effModulus * effModulus * approachSpeed), 0.2);
}

namespace {
Result<TimeStepInfo> chooseTimeStepUnchecked(const RunConfig& c);
}  // namespace

Result<TimeStepInfo> chooseTimeStep(const RunConfig& c) {
  auto info = chooseTimeStepUnchecked(c);
  if (info)
    if (Status s = checkStepCount(c.sim.duration, info->dt); !s) return s;
  return info;
}

namespace {
Result<TimeStepInfo> chooseTimeStepUnchecked(const RunConfig& c) {
  const ParticleInit& p = c.particles;
  const std::size_t n = p.size();
  const std::size_t nMat = c.materials.size();
  if (p.radius.size() != n || p.material.size() != n) {
    return invalidArgument("chooseTimeStep: particles.radius and particles.material need one entry per particle; run RunConfig::validate() first");
  }

  // T_R is proportional to R for a given material, so the smallest radius per material in use decides.
  std::vector<double> minRadius(nMat, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < n; ++i) {
    const auto m = p.material[i];
    const double r = p.radius[i];
    if (m < 0 || static_cast<std::size_t>(m) >= nMat) {
      return invalidArgument("chooseTimeStep: particles.material[" + std::to_string(i) + "]: " + std::to_string(m) +
                             " is not a material index; run RunConfig::validate() first");
    }
    if (!(std::isfinite(r) && r > 0)) {
      return invalidArgument("chooseTimeStep: particles.radius[" + std::to_string(i) + "]: " + num(r) +
                             " must be > 0; run RunConfig::validate() first");
    }
    minRadius[m] = std::min(minRadius[m], r);
  }

  double tRayleigh = std::numeric_limits<double>::infinity();
  std::size_t limiting = 0;
  for (std::size_t m = 0; m < nMat; ++m) {
    if (!std::isfinite(minRadius[m])) continue;  // not in use
    const MaterialConfig& mat = c.materials[m];
    if (!(mat.youngsModulus > 0 && std::isfinite(mat.youngsModulus) && mat.density > 0 && std::isfinite(mat.density) &&
          mat.poissonRatio > -1 && mat.poissonRatio < 0.5)) {
      return invalidArgument("chooseTimeStep: materials[" + std::to_string(m) +
                             "] needs youngs_modulus > 0, density > 0 and poisson_ratio in (-1, 0.5); run RunConfig::validate() first");
    }
    const double t = rayleighTime(minRadius[m], mat.density, mat.youngsModulus, mat.poissonRatio);
    if (t < tRayleigh) {
      tRayleigh = t;
      limiting = m;
    }
  }

  TimeStepInfo info;
  info.automatic = !c.sim.dt.has_value();
  const bool haveRayleigh = std::isfinite(tRayleigh);
  if (!haveRayleigh) {
    if (info.automatic) {
      return Status(StatusCode::kFailedPrecondition,
                    "simulation.dt: cannot choose the time step automatically without particles (no Rayleigh time); set simulation.dt");
    }
    info.dt = *c.sim.dt;
    info.reason = "dt = " + num(info.dt) + " s from simulation.dt (no particles, so no Rayleigh time to compare with)";
    return info;
  }

  info.rayleighTime = tRayleigh;
  const std::string where = "the Rayleigh time " + num(tRayleigh) + " s of material " + materialLabel(c, limiting) + " at radius " +
                            num(minRadius[limiting]) + " m";
  if (info.automatic) {
    const double f = c.sim.dtFraction;
    if (!(f > 0 && f <= 1)) {
      return invalidArgument("simulation.dt_fraction: " + num(f) + " is outside (0, 1]");
    }
    info.dt = f * tRayleigh;
    info.reason = "dt = " + num(info.dt) + " s = dt_fraction " + num(f) + " x " + where;
  } else {
    info.dt = *c.sim.dt;
    if (!(info.dt > 0 && std::isfinite(info.dt))) return invalidArgument("simulation.dt: " + num(info.dt) + " must be > 0");
    info.reason = "dt = " + num(info.dt) + " s from simulation.dt, " + num(info.dt / tRayleigh) + " of " + where;
  }
  info.fractionOfRayleigh = info.dt / tRayleigh;

  if (info.fractionOfRayleigh > kMaxSafeRayleighFraction) {
    info.warnings.push_back("dt = " + num(info.dt) + " s is " + num(info.fractionOfRayleigh) + " of the Rayleigh time " + num(tRayleigh) +
                            " s, above " + num(kMaxSafeRayleighFraction) +
                            ": expect energy gain (contacts push out harder than they were pushed in, and packings can explode) and "
                            "missed or far too deep contacts; use dt <= " + num(kMaxSafeRayleighFraction * tRayleigh) + " s (0.1-0.2 is usual)");
  }

  // Steps per contact at the fastest initial speed: two equal spheres of the smallest size of each material meeting
  // head on at twice that speed (R* = R/2, m* = m/2, E* = E / (2 (1 - nu^2))).
  double vMax = 0;
  for (const Vec3d& v : p.velocity) {
    if (isFinite(v)) vMax = std::max(vMax, norm(v));
  }
  if (vMax > 0) {
    double tContact = std::numeric_limits<double>::infinity();
    for (std::size_t m = 0; m < nMat; ++m) {
      if (!std::isfinite(minRadius[m])) continue;
      const MaterialConfig& mat = c.materials[m];
      const double r = minRadius[m];
      const double mass = mat.density * 4.0 / 3.0 * std::numbers::pi * r * r * r;
      const double eStar = mat.youngsModulus / (2.0 * (1.0 - mat.poissonRatio * mat.poissonRatio));
      tContact = std::min(tContact, hertzContactTime(0.5 * r, 0.5 * mass, eStar, 2.0 * vMax));
    }
    const double steps = tContact / info.dt;
    if (steps < kMinStepsPerContact) {
      info.warnings.push_back("at the fastest initial speed (" + num(vMax) + " m/s, two of the smallest particles meeting head on) a contact lasts " +
                              num(tContact) + " s, only " + num(steps) + " steps of dt = " + num(info.dt) + " s (want >= " +
                              num(kMinStepsPerContact) + "): contact forces will be poorly resolved and overlaps too deep; reduce dt or the initial speeds");
    }
  }
  return info;
}
}  // namespace

}  // namespace pflow::compute
