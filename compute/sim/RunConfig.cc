#include "compute/sim/RunConfig.h"

#include "compute/core/Format.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace pflow::compute {
namespace {

// Per kind of per-item error (e.g. "particles with radius <= 0"), only this many are listed one by one.
constexpr std::size_t kMaxErrorsPerKind = 20;
// A particle may start overlapping a plane by at most this fraction of its radius.
constexpr double kMaxPlaneOverlapFraction = 0.1;
constexpr int kMinHistorySlots = 1, kMaxHistorySlots = 64;
constexpr int kMaxContacts = 127;  // history slots are indexed by int8 in the candidate rows
constexpr int kMinWallHistorySlots = 1, kMaxWallHistorySlots = 32;
// Two unit normals whose dot product is below -kAntiParallel are treated as facing each other.
constexpr double kAntiParallel = 1.0 - 1e-9;
// A triangle is degenerate when |(b-a)x(c-a)| <= kDegenerate * (longest edge)^2, i.e. its smallest angle is ~0.
constexpr double kDegenerate = 1e-12;

using format::num;
using format::vec;
using format::at;
std::string percent(double fraction) { return num(100.0 * fraction) + "%"; }

// Counts errors of one kind; the first kMaxErrorsPerKind are reported, the rest become one summary line.
class Capped {
 public:
  Capped(std::string path, std::string what) : m_path(std::move(path)), m_what(std::move(what)) {}
  // True when this occurrence should be reported in full.
  bool take() { return ++m_count <= kMaxErrorsPerKind; }
  void summarize(ErrorList& out) const {
    if (m_count > kMaxErrorsPerKind) {
      out.add(m_path, "... and " + std::to_string(m_count - kMaxErrorsPerKind) + " more " + m_what);
    }
  }

 private:
  std::string m_path, m_what;
  std::size_t m_count = 0;
};

// Scalar checks. Each reports a non-finite value as such, then the bound.
bool finite(ErrorList& e, const std::string& path, double v) {
  if (std::isfinite(v)) return true;
  e.add(path, num(v) + " is not a finite number");
  return false;
}
void positive(ErrorList& e, const std::string& path, double v) {
  if (finite(e, path, v) && !(v > 0)) e.add(path, num(v) + " must be > 0");
}
void nonNegative(ErrorList& e, const std::string& path, double v) {
  if (finite(e, path, v) && !(v >= 0)) e.add(path, num(v) + " must be >= 0");
}
void openInterval(ErrorList& e, const std::string& path, double v, double lo, double hi) {
  if (finite(e, path, v) && !(v > lo && v < hi)) e.add(path, num(v) + " is outside (" + num(lo) + ", " + num(hi) + ")");
}
void leftOpenInterval(ErrorList& e, const std::string& path, double v, double lo, double hi) {
  if (finite(e, path, v) && !(v > lo && v <= hi)) e.add(path, num(v) + " is outside (" + num(lo) + ", " + num(hi) + "]");
}
void intRange(ErrorList& e, const std::string& path, long long v, long long lo, long long hi) {
  if (v < lo || v > hi) e.add(path, std::to_string(v) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
}
void finiteVec(ErrorList& e, const std::string& path, const Vec3d& v) {
  if (!isFinite(v)) e.add(path, vec(v) + " is not finite");
}
void materialIndex(ErrorList& e, const std::string& path, long long m, std::size_t nMaterials) {
  if (m < 0 || static_cast<std::size_t>(m) >= nMaterials) {
    e.add(path, std::to_string(m) + " is not a material index (there " + (nMaterials == 1 ? "is 1 material" : "are " + std::to_string(nMaterials) + " materials") + ")");
  }
}

std::string planeLabel(const std::vector<PlaneConfig>& planes, std::size_t i) {
  const std::string p = at("planes", i);
  return planes[i].name.empty() ? p : "'" + planes[i].name + "' (" + p + ")";
}

void validateMaterials(const RunConfig& c, ErrorList& e) {
  if (c.materials.empty()) e.add("materials", "at least one material is required");
  std::map<std::string, std::size_t> names;
  for (std::size_t i = 0; i < c.materials.size(); ++i) {
    const MaterialConfig& m = c.materials[i];
    const std::string p = at("materials", i);
    if (!m.name.empty()) {
      auto [it, inserted] = names.emplace(m.name, i);
      if (!inserted) e.add(p + ".name", "'" + m.name + "' is already the name of " + at("materials", it->second));
    }
    positive(e, p + ".youngs_modulus", m.youngsModulus);
    openInterval(e, p + ".poisson_ratio", m.poissonRatio, -1.0, 0.5);
    positive(e, p + ".density", m.density);
    leftOpenInterval(e, p + ".restitution", m.restitution, 0.0, 1.0);
    nonNegative(e, p + ".friction", m.friction);
    nonNegative(e, p + ".rolling_friction", m.rollingFriction);
    if (m.fixed && i >= 64) e.add(p + ".fixed", "only the first 64 materials may be fixed (this is material " + std::to_string(i + 1) + ")");
  }
}

// Adhesion: a work of adhesion > 0, and a JKR contact's reach past zero overlap (its break distance for the
// largest particles of the pair, sphere-sphere and sphere-wall) within half the neighbour skin, so that every contact
// that holds is among the candidates of every rebuild.
void validateCohesion(const RunConfig& c, const MaterialPairConfig& pr, const std::string& p, ErrorList& e) {
  const std::string w = p + ".work_of_adhesion";
  if (!std::isfinite(pr.workOfAdhesion) || pr.workOfAdhesion <= 0) {
    e.add(w, "must be > 0 (J/m^2), got " + num(pr.workOfAdhesion));
    return;
  }
  const int nMat = int(c.materials.size());
  if (pr.cohesion != CohesionModel::kJkr || pr.a < 0 || pr.b < 0 || pr.a >= nMat || pr.b >= nMat) return;
  double rMax = 0;
  for (double r : c.particles.radius) rMax = std::max(rMax, r);
  double skin = c.sim.skin;
  if (skin < 0) skin = 0.2 * rMax;
  const MaterialConfig& ma = c.materials[std::size_t(pr.a)];
  const MaterialConfig& mb = c.materials[std::size_t(pr.b)];
  if (!(ma.youngsModulus > 0) || !(mb.youngsModulus > 0) || rMax <= 0 || !(skin > 0)) return;
  const double effYoung = 1.0 / ((1 - ma.poissonRatio * ma.poissonRatio) / ma.youngsModulus +
                                 (1 - mb.poissonRatio * mb.poissonRatio) / mb.youngsModulus);
  const double pg = std::numbers::pi * pr.workOfAdhesion / effYoung;
  const double reach = 0.75 * std::cbrt(pg * pg) * std::cbrt(rMax);  // R* <= r_max (a wall contact)
  if (reach > 0.5 * skin)
    e.add(w, num(pr.workOfAdhesion) + " J/m^2 lets a JKR contact of the largest particles hold " + num(reach) +
                 " m past touching, more than half the neighbour skin " + num(skin) +
                 " m: such contacts could be lost at a rebuild; raise simulation.skin above " + num(2 * reach) + " m");
}

void validatePairs(const RunConfig& c, ErrorList& e) {
  const std::size_t nMat = c.materials.size();
  std::map<std::pair<int, int>, std::size_t> seen;
  for (std::size_t i = 0; i < c.pairs.size(); ++i) {
    const MaterialPairConfig& pr = c.pairs[i];
    const std::string p = at("pairs", i);
    materialIndex(e, p + ".materials[0]", pr.a, nMat);
    materialIndex(e, p + ".materials[1]", pr.b, nMat);
    auto [it, inserted] = seen.emplace(std::minmax(pr.a, pr.b), i);
    if (!inserted) e.add(p, "overrides the same material pair as " + at("pairs", it->second));
    if (pr.restitution) leftOpenInterval(e, p + ".restitution", *pr.restitution, 0.0, 1.0);
    if (pr.friction) nonNegative(e, p + ".friction", *pr.friction);
    if (pr.rollingFriction) nonNegative(e, p + ".rolling_friction", *pr.rollingFriction);
    if (pr.cohesion != CohesionModel::kNone) validateCohesion(c, pr, p + ".cohesion", e);
  }
}

void validatePlanes(const RunConfig& c, ErrorList& e) {
  for (std::size_t i = 0; i < c.planes.size(); ++i) {
    const PlaneConfig& pl = c.planes[i];
    const std::string p = at("planes", i);
    finiteVec(e, p + ".point", pl.point);
    if (!isFinite(pl.normal)) {
      e.add(p + ".normal", vec(pl.normal) + " is not finite");
    } else if (norm2(pl.normal) == 0.0) {
      e.add(p + ".normal", "[0, 0, 0] is not a direction: the normal must be nonzero");
    }
    materialIndex(e, p + ".material", pl.material, c.materials.size());
  }
}

// motion.drive: a translation drive (mass) with a constant force or a force limit on holding the velocity, a rotation
// drive (moment of inertia) with a constant torque or a torque limit on holding the angular velocity; no vibration
// or velocity profile beside it.
void validateDrive(const MeshMotion& mo, const std::string& mp, ErrorList& e) {
  const MeshMotion::Drive& d = *mo.drive;
  const std::string dp = mp + ".drive";
  if (!(d.mass >= 0)) e.add(dp + ".mass", num(d.mass) + " must be > 0 (kg)");
  if (!(d.inertia >= 0)) e.add(dp + ".moment_of_inertia", num(d.inertia) + " must be > 0 (kg m^2)");
  finiteVec(e, dp + ".force", d.force);
  nonNegative(e, dp + ".force_limit", d.forceLimit);
  finite(e, dp + ".torque", d.torque);
  nonNegative(e, dp + ".torque_limit", d.torqueLimit);
  const bool force = isFinite(d.force) && norm2(d.force) > 0, speed = isFinite(mo.velocity) && norm2(mo.velocity) > 0;
  if (!d.translates() && !d.rotates())
    e.add(dp, "drives nothing: give mass (kg, with force or force_limit) and/or moment_of_inertia (kg m^2, with torque or "
              "torque_limit)");
  if (d.translates()) {
    if (force && d.forceLimit > 0) e.add(dp + ".force_limit", "give force (a constant drive) or force_limit (holding motion.velocity), not both");
    else if (!force && !(d.forceLimit > 0)) e.add(dp + ".force", "a translation drive (mass " + num(d.mass) + " kg) needs force (N) or force_limit (N) with motion.velocity");
    else if (d.forceLimit > 0 && !speed) e.add(mp + ".velocity", "force_limit holds a velocity: give motion.velocity (its direction is the guide's)");
    else if (force && speed) e.add(mp + ".velocity", "a constant-force drive starts at rest along the force: leave motion.velocity out");
  } else if (force || d.forceLimit > 0) {
    e.add(dp + ".mass", "a drive force needs the wall's mass (kg)");
  }
  if (d.rotates()) {
    if (d.torque != 0 && d.torqueLimit > 0) e.add(dp + ".torque_limit", "give torque (a constant drive) or torque_limit (holding motion.angular_velocity), not both");
    else if (d.torque == 0 && !(d.torqueLimit > 0)) e.add(dp + ".torque", "a rotation drive (moment of inertia " + num(d.inertia) + " kg m^2) needs torque (N m) or torque_limit (N m) with motion.angular_velocity");
    else if (d.torqueLimit > 0 && mo.angularSpeed == 0) e.add(mp + ".angular_velocity", "torque_limit holds an angular velocity: give motion.angular_velocity");
    else if (d.torque != 0 && mo.angularSpeed != 0) e.add(mp + ".angular_velocity", "a constant-torque drive starts at rest: leave motion.angular_velocity out");
    if (isFinite(mo.axis) && norm2(mo.axis) == 0.0) e.add(mp + ".axis", "[0, 0, 0] is not a direction: a rotation drive turns about motion.axis");
  } else if (d.torque != 0 || d.torqueLimit > 0) {
    e.add(dp + ".moment_of_inertia", "a drive torque needs the wall's moment of inertia about the axis (kg m^2)");
  }
  if (mo.vibrates()) e.add(mp + ".vibration", "a driven wall moves by its drive: no vibration beside it");
  if (!mo.profile.empty()) e.add(mp + ".velocity_profile", "a driven wall moves by its drive: no velocity profile beside it");
  if (!d.translates() && speed) e.add(mp + ".velocity", "a rotation drive alone: the wall does not translate (give drive.mass to drive it)");
  if (!d.rotates() && mo.angularSpeed != 0) e.add(mp + ".angular_velocity", "a translation drive alone: the wall does not turn (give drive.moment_of_inertia to drive it)");
}

void validateMeshes(const RunConfig& c, ErrorList& e) {
  for (std::size_t i = 0; i < c.meshes.size(); ++i) {
    const MeshConfig& m = c.meshes[i];
    const std::string p = at("meshes", i);
    const std::size_t nv = m.vertices.size();

    Capped badVertex(p + ".vertices", "vertices that are not finite");
    for (std::size_t v = 0; v < nv; ++v) {
      if (!isFinite(m.vertices[v]) && badVertex.take()) e.add(at(p + ".vertices", v), vec(m.vertices[v]) + " is not finite");
    }
    badVertex.summarize(e);

    if (m.triangles.empty()) e.add(p + ".triangles", "the mesh has no triangles");
    Capped badIndex(p + ".triangles", "triangles with a vertex index out of range");
    Capped degenerate(p + ".triangles", "degenerate (zero-area) triangles");
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      const auto& tri = m.triangles[t];
      auto tp = [&] { return at(p + ".triangles", t); };
      auto triText = [&tri] {
        std::string out = "[";
        out.append(std::to_string(tri[0])).append(", ").append(std::to_string(tri[1])).append(", ").append(std::to_string(tri[2])).append("]");
        return out;
      };
      if (tri[0] >= nv || tri[1] >= nv || tri[2] >= nv) {
        if (badIndex.take()) {
          e.add(tp(), "triangle " + triText() + " refers to a vertex outside [0, " + std::to_string(nv) + ")" +
                        (nv == 0 ? " (the mesh has no vertices)" : ""));
        }
        continue;
      }
      const Vec3d a = m.vertices[tri[0]], b = m.vertices[tri[1]], cc = m.vertices[tri[2]];
      if (!isFinite(a) || !isFinite(b) || !isFinite(cc)) continue;  // reported with the vertex
      const double longest2 = std::max({norm2(b - a), norm2(cc - a), norm2(cc - b)});
      const double area2 = norm(cross(b - a, cc - a));  // twice the area
      if (!(area2 > kDegenerate * longest2) && degenerate.take()) {
        e.add(tp(), "triangle " + triText() + " is degenerate (zero area): its corners " + vec(a) + ", " + vec(b) + ", " + vec(cc) +
                      " are collinear or coincide");
      }
    }
    badIndex.summarize(e);
    degenerate.summarize(e);

    if (!m.surface.empty() && m.surface.size() != m.triangles.size()) {
      e.add(p + ".surfaces", "has " + std::to_string(m.surface.size()) + " entries; expected 0 (all surface 0) or " +
                                 std::to_string(m.triangles.size()) + " (one per triangle)");
    }
    Capped badSurface(p + ".surfaces", "negative surface numbers");
    for (std::size_t t = 0; t < m.surface.size(); ++t) {
      if (m.surface[t] < 0 && badSurface.take()) e.add(at(p + ".surfaces", t), std::to_string(m.surface[t]) + " must be >= 0");
    }
    badSurface.summarize(e);

    materialIndex(e, p + ".material", m.material, c.materials.size());

    const MeshMotion& mo = m.motion;
    const std::string mp = p + ".motion";
    finiteVec(e, mp + ".velocity", mo.velocity);
    finiteVec(e, mp + ".axis_point", mo.axisPoint);
    finiteVec(e, mp + ".axis", mo.axis);
    finite(e, mp + ".angular_velocity", mo.angularSpeed);
    nonNegative(e, mp + ".start_time", mo.startTime);
    if (mo.angularSpeed != 0 && isFinite(mo.axis) && norm2(mo.axis) == 0.0) {
      e.add(mp + ".axis", "[0, 0, 0] is not a direction: the rotation axis must be nonzero when angular_velocity is " + num(mo.angularSpeed));
    }
    finiteVec(e, mp + ".vibration.amplitude", mo.vibration);
    nonNegative(e, mp + ".vibration.frequency", mo.frequency);
    finite(e, mp + ".vibration.phase", mo.phase);
    if (isFinite(mo.vibration) && norm2(mo.vibration) > 0 && !(mo.frequency > 0))
      e.add(mp + ".vibration.frequency", "must be > 0 (Hz) for a vibration of amplitude " + vec(mo.vibration) + " m");
    if (!mo.profile.empty()) {
      if (mo.profile.size() > std::size_t(kMaxProfilePoints))
        e.add(mp + ".velocity_profile", std::to_string(mo.profile.size()) + " points: at most " + std::to_string(kMaxProfilePoints));
      if (norm2(mo.velocity) != 0) e.add(mp + ".velocity", "give velocity or velocity_profile, not both");
      for (std::size_t k = 0; k < mo.profile.size(); ++k) {
        const std::string pp = mp + ".velocity_profile[" + std::to_string(k) + "]";
        nonNegative(e, pp + " time", mo.profile[k].tau);
        finiteVec(e, pp + " velocity", mo.profile[k].velocity);
        if (k > 0 && !(mo.profile[k].tau > mo.profile[k - 1].tau))
          e.add(pp, "time " + num(mo.profile[k].tau) + " s must be after the previous point's " + num(mo.profile[k - 1].tau) + " s");
      }
    }
    if (mo.drive) validateDrive(mo, mp, e);
  }
}

}  // namespace

std::string stepCountProblem(double duration, double dt) {
  if (!(dt > 0) || !(duration > 0)) return {};  // validate() names these
  const double steps = duration / dt;
  if (steps <= kMaxSteps) return {};
  return num(duration) + " s at dt " + num(dt) + " s is " + num(steps) + " steps; a run may take at most " + num(kMaxSteps);
}

Status checkStepCount(double duration, double dt) {
  const std::string problem = stepCountProblem(duration, dt);
  return problem.empty() ? Status::ok() : invalidArgument("simulation.duration: " + problem);
}

namespace {

void validateSimulation(const RunConfig& c, ErrorList& e) {
  const SimulationSettings& s = c.sim;
  finiteVec(e, "simulation.gravity", s.gravity);
  if (s.dt) positive(e, "simulation.dt", *s.dt);
  positive(e, "simulation.duration", s.duration);
  leftOpenInterval(e, "simulation.dt_fraction", s.dtFraction, 0.0, 1.0);
  if (finite(e, "simulation.skin", s.skin) && s.skin == 0.0) {
    e.add("simulation.skin", "0 is invalid: give a distance > 0 (m), or a negative value (auto) for 0.1 x the largest particle diameter");
  }
  nonNegative(e, "simulation.snapshot_interval", s.snapshotInterval);
  if (s.domain) {
    const Vec3d lo = s.domain->lo, hi = s.domain->hi;
    if (!isFinite(lo) || !isFinite(hi)) {
      e.add("simulation.domain", "min " + vec(lo) + " and max " + vec(hi) + " must be finite");
    } else {
      const char* axes = "xyz";
      const double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
      for (int k = 0; k < 3; ++k) {
        if (!(h[k] > l[k])) {
          e.add("simulation.domain", std::string("max.") + axes[k] + " (" + num(h[k]) + ") must be > min." + axes[k] + " (" + num(l[k]) + ")");
        }
      }
    }
  }
  intRange(e, "simulation.history_slots", s.historySlots, kMinHistorySlots, kMaxHistorySlots);
  intRange(e, "simulation.wall_history_slots", s.wallHistorySlots, kMinWallHistorySlots, kMaxWallHistorySlots);
  if (s.threads < 0) e.add("simulation.threads", std::to_string(s.threads) + " must be >= 0 (0 = all cores)");
  if (finite(e, "simulation.max_overlap", s.maxOverlap) && !(s.maxOverlap > 0 && s.maxOverlap <= 1)) {
    e.add("simulation.max_overlap", num(s.maxOverlap) + " must be in (0, 1]: the overlap limit as a fraction of the smaller radius");
  }
  intRange(e, "simulation.max_contacts", s.maxContacts, 1, kMaxContacts);
  if (s.maxContacts < s.historySlots && s.historySlots <= kMaxHistorySlots && s.maxContacts >= 1) {
    e.add("simulation.max_contacts", std::to_string(s.maxContacts) + " must be >= simulation.history_slots (" +
                                         std::to_string(s.historySlots) + ")");
  }
  if (s.checkpointSteps < 1) e.add("simulation.checkpoint_steps", std::to_string(s.checkpointSteps) + " must be >= 1");
  if (s.rebuildInterval < 0)
    e.add("simulation.rebuild_interval", std::to_string(s.rebuildInterval) + " must be >= 0 (0 = automatic from the skin)");
  if (s.accuracy) {
    if (s.accuracy->quantity.empty()) e.add("simulation.accuracy.quantity", "is empty: name the reference quantity (e.g. restitution)");
    positive(e, "simulation.accuracy.tolerance", s.accuracy->tolerance);
  }
}

// Per-particle checks (capped per kind), particle-vs-plane checks in O(N * planes), and facing planes.
void validateParticles(const RunConfig& c, ErrorList& e) {
  const ParticleInit& pi = c.particles;
  const std::size_t n = pi.size();
  auto lengthCheck = [&](const char* path, std::size_t size, bool emptyOk) {
    if (size == n || (emptyOk && size == 0)) return;
    e.add(path, "has " + std::to_string(size) + " entries; expected " + (emptyOk ? "0 (all zero) or " : "") + std::to_string(n) +
                    " (one per particle position)");
  };
  lengthCheck("particles.velocity", pi.velocity.size(), true);
  lengthCheck("particles.angular_velocity", pi.angularVelocity.size(), true);
  lengthCheck("particles.radius", pi.radius.size(), false);
  lengthCheck("particles.material", pi.material.size(), false);

  // Planes usable for the particle checks: finite point, finite nonzero normal.
  struct UnitPlane {
    std::size_t index;
    Vec3d point, normal;
  };
  std::vector<UnitPlane> planes;
  for (std::size_t k = 0; k < c.planes.size(); ++k) {
    const PlaneConfig& pl = c.planes[k];
    const double len = norm(pl.normal);
    if (isFinite(pl.point) && isFinite(pl.normal) && len > 0) planes.push_back({k, pl.point, (1.0 / len) * pl.normal});
  }

  Capped badPosition("particles.position", "particles with a non-finite position");
  Capped badVelocity("particles.velocity", "particles with a non-finite velocity");
  Capped badOmega("particles.angular_velocity", "particles with a non-finite angular velocity");
  Capped nonFiniteRadius("particles.radius", "particles with a non-finite radius");
  Capped badRadius("particles.radius", "particles with radius <= 0");
  Capped badMaterial("particles.material", "particles with an invalid material index");
  Capped outside("particles.position", "particles outside simulation.domain");
  Capped movingFixed("particles.velocity", "particles of a fixed material given a velocity or a spin");
  std::vector<Capped> behind, overlapping;
  for (const UnitPlane& up : planes) {
    behind.emplace_back("particles.position", "particles behind plane " + planeLabel(c.planes, up.index));
    overlapping.emplace_back("particles.position", "particles overlapping plane " + planeLabel(c.planes, up.index) + " too deeply");
  }
  // Particles are checked against the domain only when it is itself valid (else that is the one error).
  const bool domainOk = c.sim.domain && isFinite(c.sim.domain->lo) && isFinite(c.sim.domain->hi) && c.sim.domain->hi.x > c.sim.domain->lo.x &&
                        c.sim.domain->hi.y > c.sim.domain->lo.y && c.sim.domain->hi.z > c.sim.domain->lo.z;
  double minRadius = std::numeric_limits<double>::infinity();

  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d x = pi.position[i];
    const bool xOk = isFinite(x);
    if (!xOk && badPosition.take()) e.add(at("particles.position", i), vec(x) + " is not finite");
    if (i < pi.velocity.size() && !isFinite(pi.velocity[i]) && badVelocity.take()) {
      e.add(at("particles.velocity", i), vec(pi.velocity[i]) + " is not finite");
    }
    if (i < pi.angularVelocity.size() && !isFinite(pi.angularVelocity[i]) && badOmega.take()) {
      e.add(at("particles.angular_velocity", i), vec(pi.angularVelocity[i]) + " is not finite");
    }
    bool rOk = false;
    double r = 0;
    if (i < pi.radius.size()) {
      r = pi.radius[i];
      if (!std::isfinite(r)) {
        if (nonFiniteRadius.take()) e.add(at("particles.radius", i), num(r) + " is not a finite number");
      } else if (!(r > 0)) {
        if (badRadius.take()) e.add(at("particles.radius", i), num(r) + " must be > 0");
      } else {
        rOk = true;
        minRadius = std::min(minRadius, r);
      }
    }
    if (i < pi.material.size()) {
      const auto m = pi.material[i];
      if ((m < 0 || static_cast<std::size_t>(m) >= c.materials.size()) && badMaterial.take()) {
        materialIndex(e, at("particles.material", i), m, c.materials.size());
      } else if (m >= 0 && static_cast<std::size_t>(m) < c.materials.size() && c.materials[std::size_t(m)].fixed) {
        const bool moves = (i < pi.velocity.size() && norm2(pi.velocity[i]) > 0) || (i < pi.angularVelocity.size() && norm2(pi.angularVelocity[i]) > 0);
        if (moves && movingFixed.take()) {
          e.add(at("particles.velocity", i), "is given, but the particle's material " + c.materials[std::size_t(m)].name +
                                                 " is fixed: its particles do not move");
        }
      }
    }
    if (!xOk) continue;
    if (domainOk) {
      const Vec3d lo = c.sim.domain->lo, hi = c.sim.domain->hi;
      if ((x.x < lo.x || x.y < lo.y || x.z < lo.z || x.x > hi.x || x.y > hi.y || x.z > hi.z) && outside.take()) {
        e.add(at("particles.position", i), "centre " + vec(x) + " lies outside simulation.domain (min " + vec(lo) + ", max " + vec(hi) + ")");
      }
    }
    if (!rOk) continue;
    for (std::size_t k = 0; k < planes.size(); ++k) {
      const double d = dot(x - planes[k].point, planes[k].normal);  // signed distance of the centre
      if (d < 0) {
        if (behind[k].take()) {
          e.add(at("particles.position", i), "centre " + vec(x) + " lies behind plane " + planeLabel(c.planes, planes[k].index) + " by " +
                                                  num(-d) + " m; particles must start on the side its normal " +
                                                  vec(planes[k].normal) + " points to");
        }
      } else if (r - d > kMaxPlaneOverlapFraction * r) {
        if (overlapping[k].take()) {
          e.add(at("particles.position", i), "starts overlapping plane " + planeLabel(c.planes, planes[k].index) + " by " + num(r - d) +
                                                  " m (" + percent((r - d) / r) + " of its radius " + num(r) + " m; at most " +
                                                  percent(kMaxPlaneOverlapFraction) + " is allowed)");
        }
      }
    }
  }
  for (const Capped* cap : {&badPosition, &badVelocity, &badOmega, &nonFiniteRadius, &badRadius, &badMaterial, &outside, &movingFixed}) cap->summarize(e);
  for (std::size_t k = 0; k < planes.size(); ++k) {
    behind[k].summarize(e);
    overlapping[k].summarize(e);
  }

  // Two planes with opposite normals bound a slab; it must be wider than the smallest particle.
  const double minDiameter = std::isfinite(minRadius) ? 2 * minRadius : 0.0;
  for (std::size_t a = 0; a < planes.size(); ++a) {
    for (std::size_t b = a + 1; b < planes.size(); ++b) {
      if (dot(planes[a].normal, planes[b].normal) > -kAntiParallel) continue;
      const double gap = dot(planes[b].point - planes[a].point, planes[a].normal);
      const std::string pa = planeLabel(c.planes, planes[a].index), pb = planeLabel(c.planes, planes[b].index);
      if (gap <= 0) {
        e.add(at("planes", planes[b].index), "plane " + pb + " and plane " + pa + " face away from each other (gap " + num(gap) +
                                                 " m): no point lies in front of both");
      } else if (gap < minDiameter) {
        e.add(at("planes", planes[b].index), "plane " + pb + " and plane " + pa + " face each other only " + num(gap) +
                                                 " m apart, less than the smallest particle diameter " + num(minDiameter) + " m");
      }
    }
  }
}

}  // namespace

ErrorList RunConfig::validate() const {
  if (solver == Solver::kSph) return sph.validate(sim);
  ErrorList errors;
  validateMaterials(*this, errors);
  validatePairs(*this, errors);
  validateParticles(*this, errors);
  validatePlanes(*this, errors);
  validateMeshes(*this, errors);
  validateSimulation(*this, errors);
  return errors;
}

}  // namespace pflow::compute
