#include "compute/sph/SphConfig.h"

#include <algorithm>
#include <cmath>

#include "compute/core/Format.h"
#include "compute/sph/SphLattice.h"
#include "compute/sim/RunConfig.h"

namespace pflow::compute::sph {

using format::num;

namespace {
// How far obstacles j and k of an mDBC geometry overlap along axis a [m] (negative: apart by that much).
double overlapAlong(const MdbcGeometry& m, int j, int k, int a) {
  return std::min((&m.obHi[k].x)[a], (&m.obHi[j].x)[a]) - std::max((&m.obLo[k].x)[a], (&m.obLo[j].x)[a]);
}
}  // namespace

std::size_t SphConfig::fluidCount() const {
  return std::size_t(std::count(kind.begin(), kind.end(), ParticleKind::kFluid));
}

const char* kernelName(KernelKind k) { return k == KernelKind::kWendlandC2 ? "wendland" : "cubic_spline"; }
const char* integratorName(Integrator i) {
  switch (i) {
    case Integrator::kVerlet: return "verlet";
    case Integrator::kVelocityVerlet: return "velocity_verlet";
    default: return "symplectic";
  }
}

SphDerived derive(const SphConfig& c, const SimulationSettings& sim) {
  SphDerived d;
  d.h = c.smoothingRatio * c.spacing;
  d.boundaryLayers = c.boundary == BoundaryKind::kMirror ? 0
                     : c.boundaryLayers > 0           ? c.boundaryLayers
                                                      : std::max(1, int(std::ceil(2.0 * d.h / c.spacing - 1e-9)));
  d.particleMass = c.density * std::pow(c.spacing, c.dimension);
  // The deepest fluid along gravity: the extent of the fluid particles' projections, plus one spacing (each
  // particle stands for a cell dp wide).
  const double g = norm(sim.gravity);
  double maxV = 0;
  for (std::size_t i = 0; i < c.velocity.size(); ++i)
    if (c.kind[i] == ParticleKind::kFluid) maxV = std::max(maxV, norm(c.velocity[i]));
  if (g > 0) {
    const Vec3d down = (1.0 / g) * sim.gravity;
    double lo = 1e300, hi = -1e300;
    for (std::size_t i = 0; i < c.position.size(); ++i) {
      if (c.kind[i] != ParticleKind::kFluid) continue;
      const double s = dot(c.position[i], down);
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    if (hi >= lo) d.fluidHeight = hi - lo + c.spacing;
  }
  // Ritter's dam-break front, 2 sqrt(g H), bounds the speed a column of height H reaches under gravity.
  const double ritter = 2.0 * std::sqrt(g * d.fluidHeight);
  d.expectedSpeed = std::max(ritter, maxV);
  if (c.soundSpeed) {
    d.c0 = *c.soundSpeed;
    d.soundSpeedReason = "sph.sound_speed";
  } else {
    d.c0 = 10.0 * d.expectedSpeed;
    d.soundSpeedReason = maxV > ritter ? "10 x the largest initial speed " + num(maxV) + " m/s"
                                       : "10 x 2 sqrt(g H) = 10 x " + num(ritter) + " m/s (H = " + num(d.fluidHeight) +
                                             " m, the deepest fluid)";
  }
  return d;
}

namespace {
void positive(ErrorList& e, const std::string& path, double v) {
  if (!std::isfinite(v) || !(v > 0)) e.add(path, num(v) + " must be a finite number > 0");
}
void within(ErrorList& e, const std::string& path, double v, double lo, double hi, const std::string& why = {}) {
  if (!std::isfinite(v) || v < lo || v > hi)
    e.add(path, num(v) + " is outside [" + num(lo) + ", " + num(hi) + "]" + (why.empty() ? "" : ": " + why));
}
bool inside(const SphRegion& r, const SphRegion& box, double tol) {
  return r.lo.x >= box.lo.x - tol && r.lo.y >= box.lo.y - tol && r.lo.z >= box.lo.z - tol && r.hi.x <= box.hi.x + tol &&
         r.hi.y <= box.hi.y + tol && r.hi.z <= box.hi.z + tol;
}
}  // namespace

ErrorList SphConfig::validate(const SimulationSettings& sim) const {
  ErrorList e;
  if (dimension != 2 && dimension != 3) e.add("sph.dimension", std::to_string(dimension) + " is not 2 or 3");
  positive(e, "sph.spacing", spacing);
  positive(e, "fluid.density", density);
  within(e, "sph.smoothing_ratio", smoothingRatio, 1.0, 3.0,
         "h/dp below 1 leaves too few neighbours (the seed's 1.0 gives about 12 in 2D); above 3 the kernel spans "
         "hundreds of particles for no gain in accuracy");
  if (!(gamma > 1) || !std::isfinite(gamma)) e.add("fluid.gamma", num(gamma) + " must be > 1");
  within(e, "sph.artificial_viscosity", artificialViscosity, 0.0, 1.0);
  if (!std::isfinite(kinematicViscosity) || kinematicViscosity < 0)
    e.add("fluid.kinematic_viscosity", num(kinematicViscosity) + " must be >= 0");
  within(e, "sph.density_diffusion", densityDiffusion, 0.0, 1.0);
  within(e, "sph.cfl", cfl, 1e-3, 0.5, "explicit WCSPH is stable to a Courant number of about 0.3-0.4");
  if (dt) positive(e, "sph.dt", *dt);
  within(e, "sph.skin", skin, 0.0, 2.0, "a fraction of h");
  if (verletSteps < 1) e.add("sph.verlet_steps", std::to_string(verletSteps) + " must be >= 1");
  if (integrator != Integrator::kVerlet && verletSteps != 40) e.add("sph.verlet_steps", "applies to sph.integrator: verlet");
  if (boundaryLayers < 0) e.add("sph.boundary_layers", std::to_string(boundaryLayers) + " must be >= 0 (0: automatic)");
  if (boundary == BoundaryKind::kMirror && !tank)
    e.add("sph.boundary", "mirror walls are the tank's walls: give a tank (or use sph.boundary: dynamic)");
  if (boundary == BoundaryKind::kMirror && boundaryLayers > 0)
    e.add("sph.boundary_layers", "applies to dynamic walls; mirror walls have no particles");
  if (boundary != BoundaryKind::kMirror && freeSlip) e.add("sph.wall_slip", "applies to mirror walls (sph.boundary: mirror)");
  if (mdbc && kind.size() == fluidCount())
    e.add("sph.boundary_density", "mdbc applies to boundary particles, and the scene has none");
  if (mdbc && obstacles.size() > std::size_t(MdbcGeometry::kMaxObstacles))
    e.add("sph.boundary_density", "mdbc takes at most " + std::to_string(MdbcGeometry::kMaxObstacles) + " obstacles; the scene has " +
                                      std::to_string(obstacles.size()));
  if (mdbc && spacing > 0 && obstacles.size() <= std::size_t(MdbcGeometry::kMaxObstacles)) {
    const MdbcGeometry m = mdbcGeometry(*this);
    for (int k = 0; k < m.obstacles; ++k) {
      const std::string name = obstacles[std::size_t(k)].name;
      for (int j = 0; j < k; ++j) {  // a particle in both would get one box's ghost
        bool overlap = true;
        for (int a = 0; a < 3; ++a)
          if (!(dimension == 2 && a == 1))
            overlap &= overlapAlong(m, j, k, a) > 0.5 * spacing;
        if (overlap) e.add("obstacles", name + " overlaps " + obstacles[std::size_t(j)].name + ": with sph.boundary_density: mdbc obstacles may touch but not overlap");
      }
    }
  }
  if (!(minDensityRatio > 0 && minDensityRatio < 1)) e.add("sph.density_bounds", "the lower bound " + num(minDensityRatio) + " must be in (0, 1)");
  if (!(maxDensityRatio > 1)) e.add("sph.density_bounds", "the upper bound " + num(maxDensityRatio) + " must be > 1");
  positive(e, "simulation.duration", sim.duration);
  if (!(sim.snapshotInterval >= 0)) e.add("simulation.snapshot_interval", num(sim.snapshotInterval) + " must be >= 0");
  if (!isFinite(sim.gravity)) e.add("simulation.gravity", "is not finite");
  if (!(probeInterval >= 0)) e.add("output.probe_interval", num(probeInterval) + " must be >= 0");
  if (kind.size() != position.size() || (!velocity.empty() && velocity.size() != position.size()))
    e.add("fluid", "internal: particle arrays of different lengths");
  if (!e.empty()) return e;  // the checks below need a usable spacing and density

  const SphDerived d = derive(*this, sim);
  if (d.c0 > 0 && d.h > 0)  // the first step's CFL limit (later ones may be shorter): a duration that overflows no count
    if (std::string p = stepCountProblem(sim.duration, dt ? *dt : cfl * d.h / d.c0); !p.empty()) e.add("simulation.duration", p);
  if (fluidCount() == 0) e.add("fluid.blocks", "no fluid particles: every block is empty at sph.spacing " + num(spacing) + " m");
  for (std::size_t k = 0; k < fluidBlocks.size(); ++k) {
    const SphRegion& b = fluidBlocks[k];
    const Vec3d ext = b.hi - b.lo;
    double smallest = std::min(ext.x, ext.z);
    if (dimension == 3) smallest = std::min(smallest, ext.y);
    if (smallest < 4 * d.h)
      e.add(b.name, "its smallest extent " + num(smallest) + " m is under 4 smoothing lengths (h = " + num(d.h) +
                        " m): the column is not resolved; use a smaller sph.spacing (now " + num(spacing) + " m)");
    if (tank && !inside(b, *tank, 0.5 * spacing))
      e.add(b.name, "reaches outside the tank " + tank->name + " (" + format::vec(tank->lo) + " .. " + format::vec(tank->hi) +
                        " m): the tank must contain the fluid");
    for (const SphRegion& o : obstacles) {
      const bool overlap = b.lo.x < o.hi.x && o.lo.x < b.hi.x && b.lo.z < o.hi.z && o.lo.z < b.hi.z &&
                           (dimension == 2 || (b.lo.y < o.hi.y && o.lo.y < b.hi.y));
      if (overlap) e.add(b.name, "overlaps the obstacle " + o.name + ": fluid and solid would share space");
    }
  }
  if (soundSpeed) {
    if (!(*soundSpeed > 0) || !std::isfinite(*soundSpeed)) e.add("fluid.sound_speed", num(*soundSpeed) + " must be > 0");
    else if (*soundSpeed < 10 * d.expectedSpeed)
      e.add("fluid.sound_speed", num(*soundSpeed) + " m/s is below 10 x the expected maximum speed " + num(d.expectedSpeed) +
                                     " m/s: density errors would exceed 1 % (they grow as (U/c0)^2); use at least " +
                                     num(10 * d.expectedSpeed) + " or auto");
  } else if (!(d.c0 > 0)) {
    e.add("fluid.sound_speed", "cannot be derived: no gravity and no initial speed; give it in m/s");
  }
  if (dimension == 2 && !position.empty()) {
    const double y0 = position[0].y;
    for (const Vec3d& x : position)
      if (std::fabs(x.y - y0) > 1e-12 * std::max(1.0, std::fabs(y0))) {
        e.add("sph.dimension", "2D runs keep every particle in the plane y = " + num(y0) + " m; a particle is at y = " + num(x.y));
        break;
      }
    if (sim.gravity.y != 0) e.add("simulation.gravity", "has a y component in a 2D run (the flow is in the x-z plane)");
  }
  if (size() >= std::size_t(1) << 32) e.add("sph.spacing", std::to_string(size()) + " particles: more than a run can index");
  return e;
}

MdbcGeometry mdbcGeometry(const SphConfig& c) {
  MdbcGeometry m;
  m.on = c.mdbc;
  m.planar = c.dimension == 2;
  m.tie = 1e-6 * c.spacing;
  const double half = 0.5 * c.spacing;
  Vec3d tankLo{-1e300, -1e300, -1e300}, tankHi{1e300, 1e300, 1e300};
  if (c.tank) {
    tankLo = c.tank->lo;
    tankHi = c.tank->lo + latticeFill(c, c.tank->lo, c.tank->hi).filled;
    m.tank = c.boundary != BoundaryKind::kMirror;  // mirror walls have no particles
    m.openTop = c.tankOpenTop;
    m.tankLo = tankLo;
    m.tankHi = tankHi;
  }
  m.obstacles = int(std::min<std::size_t>(c.obstacles.size(), MdbcGeometry::kMaxObstacles));
  for (int k = 0; k < m.obstacles; ++k) {
    const SphRegion& o = c.obstacles[std::size_t(k)];
    m.obLo[k] = o.lo;
    m.obHi[k] = o.lo + latticeFill(c, o.lo, o.hi).filled;
  }
  // A face meets the fluid unless it stands on the tank's wall, or against a face of another obstacle that it overlaps
  // across.
  auto against = [&](int k, int a, bool hiFace) {
    const double at = hiFace ? (&m.obHi[k].x)[a] : (&m.obLo[k].x)[a];
    if (hiFace ? at >= (&tankHi.x)[a] - half : at <= (&tankLo.x)[a] + half) return true;
    for (int j = 0; j < m.obstacles; ++j) {
      if (j == k || std::fabs((hiFace ? (&m.obLo[j].x)[a] : (&m.obHi[j].x)[a]) - at) > half) continue;
      bool across = true;
      for (int b = 0; b < 3; ++b)
        if (b != a && !(m.planar && b == 1))
          across &= overlapAlong(m, j, k, b) > half;
      if (across) return true;
    }
    return false;
  };
  for (int k = 0; k < m.obstacles; ++k)
    for (int a = 0; a < 3; ++a) {
      if (!against(k, a, false)) m.wetLo[k] |= std::uint8_t(1 << a);
      if (!against(k, a, true)) m.wetHi[k] |= std::uint8_t(1 << a);
    }
  return m;
}

std::vector<std::string> mdbcThinObstacles(const SphConfig& c) {
  std::vector<std::string> out;
  if (!c.mdbc || c.obstacles.size() > std::size_t(MdbcGeometry::kMaxObstacles)) return out;
  const MdbcGeometry m = mdbcGeometry(c);
  const double support = 2 * c.smoothingRatio * c.spacing;  // 2h
  const char* axis = "xyz";
  for (int k = 0; k < m.obstacles; ++k)
    for (int a = 0; a < 3; ++a) {  // fluid on both faces, within reach of both
      const double thick = (&m.obHi[k].x)[a] - (&m.obLo[k].x)[a];
      if ((m.wetLo[k] >> a & 1) && (m.wetHi[k] >> a & 1) && thick < 2 * support)
        out.push_back(c.obstacles[std::size_t(k)].name + " is " + num(thick) + " m thick along " + axis[a] +
                      ", under twice the kernel's support (" + num(2 * support) +
                      " m): where fluid meets both its sides, sph.boundary_density: mdbc extrapolates its particles from the nearer side only");
    }
  return out;
}

}  // namespace pflow::compute::sph
