// solver: sph scenes: the fluid, its tank and obstacles, the SPH method and the probes, read into
// RunConfig::sph; the particles generated on the lattice of sph.spacing (compute/sph/SphLattice.h).
// The keys are documented in docs/scene-format.md ("Fluids") and their physics in docs/sph.md.
#include <cmath>

#include "compute/core/Format.h"
#include "compute/sph/SphLattice.h"
#include "frontend/scene/Loader.h"

namespace pflow::frontend::detail {

using compute::sph::SphConfig;
using compute::sph::SphRegion;
using format::at;

// {name?, min, max}: a box region; a 2D run's boxes may be flat along y (min.y == max.y).
std::optional<SphRegion> Loader::parseSphBox(const Fields& f, const std::string& path) {
  SphRegion r;
  r.name = path;
  const bool lo = get(f, "min", r.lo, true), hi = get(f, "max", r.hi, true);
  if (!lo || !hi) return std::nullopt;
  const bool flatY = m_config.sph.dimension == 2;
  if (!(r.lo.x < r.hi.x) || !(r.lo.z < r.hi.z) || (!flatY && !(r.lo.y < r.hi.y)) || (flatY && r.lo.y != r.hi.y)) {
    // Built by appending: GCC 12 warns falsely (-Wrestrict) on long std::string + chains.
    std::string message = "must exceed min along every axis";
    if (flatY) message.append(" but y, which min and max share in a 2D run (the plane)");
    message.append(" (min ").append(format::vec(r.lo)).append(", max ").append(format::vec(r.hi)).append(")");
    badValue(f.child("max"), message, markFor(f.child("max")));
    return std::nullopt;
  }
  return r;
}

void Loader::parseSphScene(const Fields& top) {
  SphConfig& c = m_config.sph;
  // The method first: the lattice and the wall layers depend on it.
  if (const Entry* e = top.find("sph")) {
    if (const auto f = mapping(e->value, "sph", e->loc, kSphKeys)) {
      get(*f, "dimension", c.dimension);
      get(*f, "spacing", c.spacing, true);
      get(*f, "smoothing_ratio", c.smoothingRatio);
      if (const Entry* k = f->find("kernel")) {
        std::string name;
        if (read(k->value, f->child("kernel"), k->loc, name)) {
          if (name == "wendland") c.kernel = compute::sph::KernelKind::kWendlandC2;
          else if (name == "cubic_spline") c.kernel = compute::sph::KernelKind::kCubicSpline;
          else badValue(f->child("kernel"), unknownName("kernel", name, kSphKernels, "Choices"), k->loc);
        }
      }
      get(*f, "artificial_viscosity", c.artificialViscosity);
      get(*f, "density_diffusion", c.densityDiffusion);
      if (const Entry* k = f->find("diffusion_correction")) {
        std::string name;
        if (read(k->value, f->child("diffusion_correction"), k->loc, name)) {
          if (name == "hydrostatic" || name == "none") c.hydrostaticDiffusion = name == "hydrostatic";
          else badValue(f->child("diffusion_correction"), unknownName("correction", name, kDiffusionCorrections, "Choices"), k->loc);
        }
      }
      get(*f, "cfl", c.cfl);
      if (const Entry* k = f->find("integrator")) {
        std::string name;
        if (read(k->value, f->child("integrator"), k->loc, name)) {
          using compute::sph::Integrator;
          bool known = false;
          for (Integrator i : {Integrator::kSymplectic, Integrator::kVerlet, Integrator::kVelocityVerlet})
            if (name == compute::sph::integratorName(i)) c.integrator = i, known = true;
          if (!known) badValue(f->child("integrator"), unknownName("integrator", name, kSphIntegrators, "Choices"), k->loc);
        }
      }
      if (const Entry* k = f->find("verlet_steps")) {
        const auto v = autoOrNumber(*k, "sph.verlet_steps", "");
        if (v) {
          if (*v != std::floor(*v) || *v < 1 || *v > 1e6) badValue("sph.verlet_steps", format::num(*v) + " is not a whole number in [1, 1e6]", k->loc);
          else c.verletSteps = int(*v);
        }
      }
      if (const Entry* dt = f->find("dt")) c.dt = autoOrNumber(*dt, "sph.dt", "s");
      if (const Entry* k = f->find("boundary")) {
        std::string name;
        if (read(k->value, f->child("boundary"), k->loc, name)) {
          if (name == "dynamic" || name == "mirror") c.boundary = name == "mirror" ? compute::sph::BoundaryKind::kMirror : compute::sph::BoundaryKind::kDynamic;
          else badValue(f->child("boundary"), unknownName("boundary", name, kSphBoundaries, "Choices"), k->loc);
        }
      }
      if (const Entry* k = f->find("wall_slip")) {
        std::string name;
        if (read(k->value, f->child("wall_slip"), k->loc, name)) {
          if (name == "no_slip" || name == "free_slip") c.freeSlip = name == "free_slip";
          else badValue(f->child("wall_slip"), unknownName("wall slip", name, kWallSlips, "Choices"), k->loc);
        }
      }
      if (const Entry* k = f->find("boundary_density")) {
        std::string name;
        if (read(k->value, f->child("boundary_density"), k->loc, name)) {
          if (name == "continuity" || name == "mdbc") c.mdbc = name == "mdbc";
          else badValue(f->child("boundary_density"), unknownName("boundary density", name, kBoundaryDensities, "Choices"), k->loc);
        }
      }
      if (const Entry* b = f->find("boundary_layers")) {
        const auto v = autoOrNumber(*b, "sph.boundary_layers", "");
        if (v) {
          if (*v != std::floor(*v) || *v < 1 || *v > 16) badValue("sph.boundary_layers", format::num(*v) + " is not a whole number in [1, 16]", b->loc);
          else c.boundaryLayers = int(*v);
        }
      }
      get(*f, "skin", c.skin);
      if (const Entry* b = f->find("density_bounds")) {
        const YAML::Node& n = b->value;
        if (!n.IsSequence() || n.size() != 2) {
          badValue("sph.density_bounds", "expected [min, max] as fractions of fluid.density, e.g. [0.7, 1.3]", b->loc);
        } else {
          read(n[0], "sph.density_bounds[0]", b->loc, c.minDensityRatio);
          read(n[1], "sph.density_bounds[1]", b->loc, c.maxDensityRatio);
        }
      }
    }
  } else {
    missing(top, "sph", "at least sph.spacing");
  }
  if (const Entry* e = top.find("fluid")) {
    if (const auto f = mapping(e->value, "fluid", e->loc, kFluidKeys)) {
      get(*f, "density", c.density, true);
      if (const Entry* s = f->find("sound_speed")) c.soundSpeed = autoOrNumber(*s, "fluid.sound_speed", "m/s");
      get(*f, "gamma", c.gamma);
      get(*f, "kinematic_viscosity", c.kinematicViscosity);
    }
  } else {
    missing(top, "fluid", "the fluid's density and its blocks");
  }
  // Regions: read all, then generate only when the method is usable (a bad spacing would make no lattice).
  struct Block {
    SphRegion r;
    Vec3d v{0, 0, 0};
  };
  std::vector<Block> blocks;
  if (const Entry* e = top.find("fluid")) {
    if (e->value.IsMap() && e->value["blocks"]) {
      const YAML::Node list = e->value["blocks"];
      if (isList(list, "fluid.blocks", markFor("fluid.blocks"), "fluid blocks")) {
        for (std::size_t k = 0; k < list.size(); ++k) {
          const std::string path = at("fluid.blocks", k);
          const auto bf = mapping(list[k], path, markFor("fluid.blocks"), kFluidBlockKeys);
          if (!bf) continue;
          if (auto r = parseSphBox(*bf, path)) {
            Block b{*r, {0, 0, 0}};
            get(*bf, "velocity", b.v);
            blocks.push_back(b);
          }
        }
      }
    } else if (e->value.IsMap()) {
      badValue("fluid.blocks", "required key 'blocks' is missing (the regions filled with fluid: - {min: [..], max: [..]})", e->loc);
    }
  }
  std::optional<SphRegion> tank;
  bool openTop = true;
  if (const Entry* e = top.find("tank")) {
    if (const auto f = mapping(e->value, "tank", e->loc, kTankKeys)) {
      tank = parseSphBox(*f, "tank");
      get(*f, "open_top", openTop);
    }
  }
  std::vector<SphRegion> obstacles;
  if (const Entry* e = top.find("obstacles"); e && isList(e->value, "obstacles", e->loc, "obstacles")) {
    for (std::size_t k = 0; k < e->value.size(); ++k) {
      const std::string path = at("obstacles", k);
      if (const auto f = mapping(e->value[k], path, e->loc, kObstacleKeys))
        if (auto r = parseSphBox(*f, path)) obstacles.push_back(*r);
    }
  }
  if (const Entry* e = top.find("probes"); e && isList(e->value, "probes", e->loc, "probes")) {
    for (std::size_t k = 0; k < e->value.size(); ++k) {
      const std::string path = at("probes", k);
      const auto f = mapping(e->value[k], path, e->loc, kProbeKeys);
      if (!f) continue;
      compute::sph::SphProbe p;
      get(*f, "name", p.name, true);
      const bool point = f->find("point") != nullptr, gauge = f->find("gauge") != nullptr;
      if (point == gauge) {
        badValue(path, "give either point: [x, y, z] (a pressure probe) or gauge: [x, y, 0] (a height gauge at x, y)", f->loc);
        continue;
      }
      get(*f, point ? "point" : "gauge", p.point);
      p.gauge = gauge;
      c.probes.push_back(p);
    }
  }
  const bool methodUsable = c.spacing > 0 && std::isfinite(c.spacing) && c.smoothingRatio >= 1 && c.smoothingRatio <= 3 &&
                            (c.dimension == 2 || c.dimension == 3) && !isBad("sph");
  if (!methodUsable) return;
  // The particle count before generating any (a scene must not exhaust memory).
  double estimate = 0;
  auto volume = [&](const SphRegion& r, double pad) {
    const double dx = (r.hi.x - r.lo.x + 2 * pad) / c.spacing, dz = (r.hi.z - r.lo.z + 2 * pad) / c.spacing;
    const double dy = c.dimension == 2 ? 1.0 : (r.hi.y - r.lo.y + 2 * pad) / c.spacing;
    return dx * dy * dz;
  };
  for (const Block& b : blocks) estimate += volume(b.r, 0);
  const double layers = c.boundaryLayers > 0 ? c.boundaryLayers : std::ceil(2 * c.smoothingRatio);
  const bool mirror = c.boundary == compute::sph::BoundaryKind::kMirror;
  if (tank && !mirror) estimate += volume(*tank, layers * c.spacing);
  for (const SphRegion& o : obstacles) estimate += volume(o, 0);
  if (estimate > double(m_options.maxParticles)) {
    badValue("sph.spacing", "about " + format::num(estimate) + " particles at " + format::num(c.spacing) + " m, more than the limit of " +
                                std::to_string(m_options.maxParticles),
             markFor("sph.spacing"));
    return;
  }
  for (const Block& b : blocks) compute::sph::addFluidBlock(c, b.r.name, b.r.lo, b.r.hi, b.v);
  if (tank && mirror) compute::sph::setMirrorTank(c, "tank", tank->lo, tank->hi, openTop);
  else if (tank) compute::sph::addTank(c, "tank", tank->lo, tank->hi, openTop, c.boundaryLayers);
  for (const SphRegion& o : obstacles) compute::sph::addObstacle(c, o.name, o.lo, o.hi);
}

}  // namespace pflow::frontend::detail
