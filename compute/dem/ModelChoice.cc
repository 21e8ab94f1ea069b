#include "compute/dem/ModelChoice.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "compute/core/Format.h"
#include "compute/dem/contact/ContactParams.h"
#include "compute/dem/TimeStep.h"

namespace pflow::compute {

namespace {

std::string g(double x) { return format::num4(x); }

double component(const Vec3d& v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }

const char* const kAxis[] = {"x", "y", "z"};
const char* const kPlaneOf[] = {"y-z", "x-z", "x-y"};

// Why the scene is not planar along `axis`, or "" when it is: every centre at one coordinate along the
// axis, no velocity along it, spins only about it, no gravity along it, planes' normals perpendicular to it,
// no meshes (a triangle's closest point may lie off the particles' plane: meshes keep the run 3D).
std::string notPlanarAlong(const RunConfig& c, int axis) {
  const auto& p = c.particles;
  const std::string a = kAxis[axis];
  if (p.size() == 0) return "no particles";
  const double rmin = *std::min_element(p.radius.begin(), p.radius.end());
  const double at = component(p.position[0], axis);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (std::fabs(component(p.position[i], axis) - at) > kPlanarTolerance * rmin)
      return "the particle centres do not share one " + a + " coordinate";
  auto off = [&](const std::vector<Vec3d>& v, bool spin) {
    double largest = 0;
    for (const auto& x : v) largest = std::max(largest, norm(x));
    for (const auto& x : v) {
      for (int k = 0; k < 3; ++k) {
        const bool along = k == axis;
        if (along == spin) continue;  // velocities: the axis component; spins: the two others
        if (std::fabs(component(x, k)) > 1e-12 * largest) return true;
      }
    }
    return false;
  };
  if (off(p.velocity, false)) return "a particle has an initial velocity along " + a;
  if (off(p.angularVelocity, true)) return "a particle spins about an axis other than " + a;
  if (std::fabs(component(c.sim.gravity, axis)) > 1e-12 * norm(c.sim.gravity)) return "gravity has a " + a + " component";
  for (const auto& pl : c.planes)
    if (std::fabs(component(pl.normal, axis)) > 1e-12 * norm(pl.normal))
      return "plane '" + pl.name + "' is not parallel to " + a;
  if (!c.meshes.empty()) return "the scene has triangle meshes (2D takes planes only)";
  return "";
}

// The first material pair whose coefficient (a member of ContactParams) is nonzero, as words; "" if none.
std::string firstNonzero(const RunConfig& c, const std::vector<ContactParams>& table, double ContactParams::*member,
                         const char* what) {
  const std::size_t n = c.materials.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i; j < n; ++j) {
      const double v = table[i * n + j].*member;
      if (v == 0) continue;
      if (i == j) return "material '" + c.materials[i].name + "' has " + what + " " + g(v);
      return "materials '" + c.materials[i].name + "' and '" + c.materials[j].name + "' have " + what + " " + g(v);
    }
  return "";
}

}  // namespace

std::string ModelChoice::text() const {
  std::string out;
  for (const auto& d : decisions) out += "  " + d.name + ": " + d.choice + " — " + d.reason + "\n";
  for (const auto& p : proposals) out += "  proposed for the accuracy target, " + p.text() + "\n";
  return out;
}

ModelChoice deriveModel(const RunConfig& c, const ModelOptions& options) {
  ModelChoice m;
  m.full = c.sim.model == ModelMode::kFull;
  m.precision = c.sim.precision;
  const auto& p = c.particles;
  const std::size_t n = p.size();
  const std::string fullReason = "simulation.model: full computes every part of the model";
  auto decide = [&](std::string name, std::string choice, std::string reason) {
    m.decisions.push_back({std::move(name), std::move(choice), std::move(reason)});
  };
  decide("model", m.full ? "full" : "auto",
         m.full ? "simulation.model: full (for comparisons and benchmarks)"
                : "the least model the scene needs (simulation.model: auto, the default)");

  // ---- dimensions ----
  {
    std::string why[3];
    int axis = -1;
    for (int k = 0; k < 3 && axis < 0; ++k) {
      why[k] = notPlanarAlong(c, k);
      if (why[k].empty()) axis = k;
    }
    if (m.full) {
      decide("dimensions", "3D", fullReason);
    } else if (axis >= 0) {
      m.flags.planarAxis = axis;
      decide("dimensions", std::string("2D (discs in the ") + kPlaneOf[axis] + " plane, " + kAxis[axis] + " = " +
                               g(component(p.position[0], axis)) + " m)",
             std::string("every centre has the same ") + kAxis[axis] + ", no velocity along " + kAxis[axis] +
                 ", spins about " + kAxis[axis] + " only, gravity and every plane parallel to the plane, no meshes: " +
                 "neighbour search in one layer of cells (9 instead of 27), motion kept in the plane");
    } else {
      std::string reason = n == 0 ? "no particles" : "not planar";
      for (int k = 0; n > 0 && k < 3; ++k) reason += std::string(k ? ";" : ":") + " along " + kAxis[k] + ", " + why[k];
      decide("dimensions", "3D", reason);
    }
  }

  // ---- tangential history, rolling torque ----
  const std::vector<ContactParams> table = buildContactTable(c.materials, c.pairs);
  {
    std::string adhesive;  // the first pair with adhesion
    for (const auto& pr : c.pairs)
      if (pr.cohesion != CohesionModel::kNone && pr.workOfAdhesion > 0 && adhesive.empty() && pr.a >= 0 && pr.b >= 0 &&
          std::size_t(pr.a) < c.materials.size() && std::size_t(pr.b) < c.materials.size())
        adhesive = c.materials[std::size_t(pr.a)].name + "-" + c.materials[std::size_t(pr.b)].name;
    m.flags.cohesion = !adhesive.empty();
    decide("adhesion", m.flags.cohesion ? "on" : "off",
           m.flags.cohesion ? "the pair " + adhesive + " asks for it (pairs[].cohesion): the force loop with adhesion"
                            : "no pair asks for it (pairs[].cohesion)");
  }
  {
    const std::string nonzero = firstNonzero(c, table, &ContactParams::friction, "friction");
    if (m.full) {
      decide("tangential history", "on", fullReason);
    } else if (m.flags.cohesion) {
      decide("tangential history", "on", "adhesion: a JKR contact holds past zero overlap, and its slot says it exists");
    } else if (nonzero.empty()) {
      m.flags.tangential = false;
      decide("tangential history", "off",
             "every material and pair has friction 0: no tangential force, no history slots, no slot resolution at rebuilds");
    } else {
      decide("tangential history", "on", nonzero);
    }
  }
  {
    const std::string nonzero = firstNonzero(c, table, &ContactParams::rollingFriction, "rolling friction");
    if (m.full) {
      decide("rolling torque", "on", fullReason);
    } else if (nonzero.empty()) {
      m.flags.rolling = false;
      decide("rolling torque", "off", "every material and pair has rolling friction 0");
    } else {
      decide("rolling torque", "on", nonzero);
    }
  }

  // ---- walls ----
  {
    std::size_t triangles = 0;
    for (const auto& mc : c.meshes) triangles += mc.triangles.size();
    if (m.full) {
      decide("wall contact", "on", fullReason);
    } else if (c.planes.empty() && triangles == 0) {
      m.flags.walls = false;
      decide("wall contact", "off", "no planes and no mesh triangles: the wall phases (candidates, forces) are skipped");
    } else {
      decide("wall contact", "on",
             std::to_string(c.planes.size()) + " plane(s), " + std::to_string(c.meshes.size()) + " mesh(es) with " +
                 std::to_string(triangles) + " triangles");
    }
  }

  // ---- precision (from the accuracy target) ----
  {
    const char* name = c.sim.precision == Precision::kFloat ? "float" : "double";
    if (c.sim.precisionGiven) {
      decide("precision", name, "simulation.precision");
    } else if (!c.sim.accuracy) {
      decide("precision", name, "the default; no simulation.accuracy target to allow float");
    } else {
      const AccuracyTarget& t = *c.sim.accuracy;
      const AccuracyTable& study = options.table ? *options.table : AccuracyTable::builtIn();
      const std::string target = t.quantity + " within " + g(100 * t.tolerance) + " %";
      if (study.empty()) {
        decide("precision", name, "the accuracy table is empty (docs/accuracy/study.csv was not built in): no proposal for " + target);
      } else if (auto proposals = study.propose(t.quantity, t.tolerance); !proposals) {
        decide("precision", name, proposals.status().message());
      } else if (proposals.value().empty()) {
        decide("precision", name, "no settings of the accuracy study meet " + target);
      } else {
        m.proposals = proposals.value();
        // Float where the study measured it meeting the target at this scene's conditions: full stiffness,
        // automatic rebuilds and a dt_fraction at least the scene's (the error grows with dt), on this
        // executor (on every executor of the study when the executor is not known yet).
        const auto ts = chooseTimeStep(c);
        const double dtFraction = ts && ts.value().fractionOfRayleigh > 0 ? ts.value().fractionOfRayleigh : c.sim.dtFraction;
        std::set<std::string> executors;
        if (options.executor.empty())
          for (const auto& r : study.rows()) executors.insert(r.executor);
        else
          executors.insert(options.executor);
        bool useFloat = true;
        for (const auto& e : executors) useFloat = useFloat && study.meetsAt(t.quantity, t.tolerance, e, "float", dtFraction);
        if (useFloat && !m.full) m.precision = Precision::kFloat;
        const std::string on = options.executor.empty() ? "every executor" : "the " + options.executor + " executor";
        const std::string at = " at dt_fraction " + g(dtFraction) + " or more, full stiffness, automatic rebuilds, on " + on;
        decide("precision", useFloat && !m.full ? "float" : name,
               std::string(useFloat ? (m.full ? "float would meet " : "float meets ") : "the study has no float run meeting ") +
                   target + at + (m.full && useFloat ? ", but simulation.model: full keeps the scene's" : "") +
                   "; the study's cheapest settings meeting it are listed below (softening, skin and rebuild interval "
                   "are study parameters: soften by lowering youngs_modulus)");
      }
    }
  }

  // ---- cell size ----
  {
    double maxR = 0;
    for (double r : p.radius) maxR = std::max(maxR, r);
    const double skin = c.sim.skin > 0 ? c.sim.skin : 0.2 * maxR;
    m.cellSize = 2 * maxR + skin;
    std::string reason = "2 × the largest radius (" + g(maxR) + " m) + skin (" + g(skin) + " m)";
    if (n > 0) {
      std::vector<double> r = p.radius;
      std::nth_element(r.begin(), r.begin() + std::ptrdiff_t(n / 2), r.end());
      const double median = r[n / 2];
      const double ratio = maxR / median;
      const double dims = m.flags.planarAxis < 0 ? 3.0 : 2.0;
      if (ratio > 1.5) {
        // The searched block (27 or 9 cells) against one of cells sized for median particles (2.2 r_median with
        // the default skin): candidates to test grow with the ratio of their volumes (areas in 2D).
        const double waste = std::pow(m.cellSize / (2.2 * median), dims);
        reason += "; polydisperse: the largest radius is " + g(ratio) + " × the median (" + g(median) +
                  " m), so a median particle searches " + g(waste) + " × the " + (dims == 3 ? "volume" : "area") +
                  " that cells sized for it would: wasteful; a grid per size class would cut it (not implemented)";
      } else {
        reason += "; sizes within 1.5 × of the median: one cell size suits them";
      }
    }
    if (m.flags.planarAxis >= 0) reason += "; one layer of cells along " + std::string(kAxis[m.flags.planarAxis]);
    decide("cell size", g(m.cellSize) + " m", reason);
  }

  // ---- GPU count ----
  {
    const std::uint64_t per = std::max<std::uint64_t>(1, options.particlesPerGpu);
    m.gpus = int(std::max<std::uint64_t>(1, std::uint64_t(n) / per));
    decide("GPUs", std::to_string(m.gpus),
           std::to_string(n) + " particles at " + std::to_string(per) +
               " per GPU (the manager's --particles-per-gpu default); the manager gives fewer when fewer exist or "
               "more when the model does not fit in one GPU's memory");
  }
  return m;
}

}  // namespace pflow::compute
