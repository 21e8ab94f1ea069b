#include "frontend/scene/Loader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "compute/core/Format.h"
#include "frontend/generators/Random.h"
#include "frontend/scene/WallClearance.h"

namespace pflow::frontend::detail {

using format::at;
using format::num;
using format::vec;

void Loader::addParticle(const Vec3d& x, double r, const Vec3d& v, const Vec3d& w, int material) {
  compute::ParticleInit& p = m_config.particles;
  const std::size_t i = p.position.size();
  p.position.push_back(x);
  p.radius.push_back(r);
  p.material.push_back(material);
  // Velocity arrays stay empty (= all zero) until some particle moves; then they hold one entry per particle.
  auto append = [i](std::vector<Vec3d>& values, const Vec3d& value) {
    if (values.empty() && value.x == 0 && value.y == 0 && value.z == 0) return;
    values.resize(i, Vec3d{0, 0, 0});
    values.push_back(value);
  };
  append(p.velocity, v);
  append(p.angularVelocity, w);
}

std::optional<Vec3d> Loader::readVec(const Fields& f, std::string_view key) {
  Vec3d v{0, 0, 0};
  if (!f.find(key)) return v;
  if (!get(f, key, v)) return std::nullopt;
  return v;
}

// `size`: a number (one radius) or {distribution: ..., parameters}. Radii in metres.
std::optional<SizeDistribution> Loader::parseSize(const Fields& set) {
  const Entry* e = set.find("size");
  const std::string path = set.child("size");
  if (!e) {
    missing(set, "size", "a radius in m, or {distribution: uniform, min: .., max: ..} and the like");
    return std::nullopt;
  }
  if (e->value.IsScalar()) {
    double r = 0;
    if (!read(e->value, path, e->loc, r)) return std::nullopt;
    SizeDistribution d = SizeDistribution::single(r);
    if (ErrorList errs = d.validate(path); !errs.empty()) {
      badValue(path, num(r) + " must be > 0 (a radius in m)", e->loc);
      return std::nullopt;
    }
    return d;
  }
  const auto f = mapping(e->value, path, e->loc, kSizeKeys);
  if (!f) return std::nullopt;
  std::string kind = f->find("radius") && !f->find("distribution") ? "single" : "";
  if (const Entry* d = f->find("distribution")) {
    if (!read(d->value, f->child("distribution"), d->loc, kind)) return std::nullopt;
    if (std::find(std::begin(kDistributions), std::end(kDistributions), kind) == std::end(kDistributions)) {
      badValue(f->child("distribution"), unknownName("distribution", kind, kDistributions, "Choices"), d->loc);
      return std::nullopt;
    }
  } else if (kind.empty()) {
    missing(*f, "distribution", "one of " + joinNames(kDistributions) + ", or just 'radius'");
    return std::nullopt;
  }
  // The parameters each distribution takes; any other key is an error naming the ones it does take.
  const std::vector<std::string_view> params = kind == "single"    ? std::vector<std::string_view>{"radius"}
                                               : kind == "uniform" ? std::vector<std::string_view>{"min", "max"}
                                               : kind == "normal"  ? std::vector<std::string_view>{"mean", "std", "min", "max"}
                                               : kind == "lognormal" ? std::vector<std::string_view>{"median", "geometric_std", "min", "max"}
                                                                     : std::vector<std::string_view>{"radii", "fractions", "basis"};
  bool ok = true;
  for (const Entry& entry : f->entries) {
    if (entry.key == "distribution" || std::find(params.begin(), params.end(), entry.key) != params.end()) continue;
    badValue(f->child(entry.key), "'" + entry.key + "' is not a parameter of a " + kind + " distribution (it takes " + joinNames(params) + ")",
             entry.keyLoc);
    ok = false;
  }
  double a = 0, b = 0, lo = 0, hi = 0;
  auto need = [&](std::string_view key, double& out) { ok &= get(*f, key, out, true); };
  std::optional<SizeDistribution> d;
  if (kind == "single") {
    need("radius", a);
    if (ok) d = SizeDistribution::single(a);
  } else if (kind == "uniform") {
    need("min", lo);
    need("max", hi);
    if (ok) d = SizeDistribution::uniform(lo, hi);
  } else if (kind == "normal") {
    need("mean", a);
    need("std", b);
    need("min", lo);
    need("max", hi);
    if (ok) d = SizeDistribution::normal(a, b, lo, hi);
  } else if (kind == "lognormal") {
    need("median", a);
    need("geometric_std", b);
    need("min", lo);
    need("max", hi);
    if (ok) d = SizeDistribution::logNormal(a, b, lo, hi);
  } else {
    std::vector<double> radii, fractions;
    auto numbers = [&](std::string_view key, std::vector<double>& out) {
      const Entry* ne = f->find(key);
      if (!ne) return missing(*f, key), void(ok = false);
      const std::string np = f->child(key);
      if (!isList(ne->value, np, ne->loc, "numbers")) return void(ok = false);
      for (std::size_t k = 0; k < ne->value.size(); ++k) {
        double v = 0;
        ok &= read(ne->value[k], at(np, k), ne->loc, v);
        out.push_back(v);
      }
    };
    numbers("radii", radii);
    numbers("fractions", fractions);
    SizeDistribution::Basis basis = SizeDistribution::Basis::kNumber;
    if (const Entry* be = f->find("basis")) {
      std::string bname;
      if (read(be->value, f->child("basis"), be->loc, bname)) {
        if (bname == "volume") basis = SizeDistribution::Basis::kVolume;
        else if (bname != "number") badValue(f->child("basis"), unknownName("basis", bname, kBases, "Choices"), be->loc), ok = false;
      } else {
        ok = false;
      }
    }
    if (ok) d = SizeDistribution::discrete(std::move(radii), std::move(fractions), basis);
  }
  if (!d) return std::nullopt;
  if (ErrorList errs = d->validate(path); !errs.empty()) {
    for (const FieldError& fe : errs.errors()) badValue(fe.path, fe.message, markFor(fe.path));
    return std::nullopt;
  }
  return d;
}

// `region`: {box: {min, max}}, {cylinder: {base, axis, radius, height}} or {mesh: <name of a closed wall>}.
std::optional<Region> Loader::parseParticleRegion(const Fields& set) {
  const Entry* e = set.find("region");
  const std::string path = set.child("region");
  if (!e) {
    missing(set, "region", "{box: {min: [..], max: [..]}}, {cylinder: {...}} or {mesh: <wall name>}");
    return std::nullopt;
  }
  const auto f = mapping(e->value, path, e->loc, kRegionShapes);
  if (!f) return std::nullopt;
  if (f->entries.size() != 1) {
    badValue(path, "expected exactly one of " + joinNames(kRegionShapes), f->loc);
    return std::nullopt;
  }
  const Entry& shape = f->entries.front();
  const std::string sp = f->child(shape.key);
  Result<Region> region = invalidArgument("");
  if (shape.key == "box") {
    const auto bf = mapping(shape.value, sp, shape.loc, kRegionKeys);
    if (!bf) return std::nullopt;
    Vec3d lo{0, 0, 0}, hi{0, 0, 0};
    const bool haveLo = get(*bf, "min", lo, true), haveHi = get(*bf, "max", hi, true);  // both, to report both
    if (!haveLo || !haveHi) return std::nullopt;
    if (!isFinite(lo) || !isFinite(hi) || !(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z)) {
      badValue(sp, "max " + vec(hi) + " must be > min " + vec(lo) + " on every axis", bf->loc);
      return std::nullopt;
    }
    region = Region::box(lo, hi);
  } else if (shape.key == "cylinder") {
    const auto cf = mapping(shape.value, sp, shape.loc, kCylinderRegionKeys);
    if (!cf) return std::nullopt;
    Vec3d base{0, 0, 0}, axis{0, 0, 1};
    double radius = 0, height = 0;
    bool ok = get(*cf, "base", base, true);
    ok &= unitAxis(*cf, "axis", axis);
    ok &= positive(*cf, "radius", radius, true);
    ok &= positive(*cf, "height", height, true);
    if (!ok) return std::nullopt;
    region = Region::cylinder(base, axis, radius, height);
  } else {
    std::string wall;
    if (!read(shape.value, sp, shape.loc, wall)) return std::nullopt;
    std::vector<std::string> meshNames;
    const MeshConfig* mesh = nullptr;
    for (const MeshConfig& m : m_config.meshes) {
      meshNames.push_back(m.name);
      if (m.name == wall) mesh = &m;
    }
    if (!mesh) {
      badValue(sp, meshNames.empty() ? "unknown wall '" + wall + "': the scene has no mesh walls (region: mesh names a closed wall)"
                                     : unknownName("mesh wall", wall, meshNames, "Mesh walls"),
               shape.loc);
      return std::nullopt;
    }
    TriMesh tm;
    tm.vertices = mesh->vertices;
    tm.triangles = mesh->triangles;
    tm.surface.assign(tm.triangles.size(), 0);
    region = Region::mesh(tm);
    if (!region) {
      badValue(sp, "wall '" + wall + "' cannot be a region: " + region.status().message(), shape.loc);
      return std::nullopt;
    }
  }
  if (!region) {
    badValue(sp, region.status().message(), shape.loc);
    return std::nullopt;
  }
  return std::move(region).value();
}

bool Loader::parseParticleList(const Fields& f, const Vec3d& v0, const Vec3d& w0, Particles& out, std::vector<Vec3d>& vel,
                               std::vector<Vec3d>& spin, ParticleSet& set) {
  const Entry* list = f.find("list");
  const Entry* file = f.find("file");
  if (list && file) {
    badValue(f.path, "give either 'list' (inline particles) or 'file' (a CSV file), not both", f.loc);
    return false;
  }
  if (!list && !file) {
    missing(f, "list", "method list takes inline particles in 'list' or a CSV file in 'file'");
    return false;
  }
  if (file) {
    std::string name;
    if (!read(file->value, f.child("file"), file->loc, name)) return false;
    m_files.push_back(name);
    auto input = resolveInput(name);
    if (!input) {
      badValue(f.child("file"), input.status().message(), file->loc);
      return false;
    }
    auto csv = readParticleCsv(input.value());
    if (!csv) {
      badValue(f.child("file"), csv.status().message(), file->loc);
      return false;
    }
    if (csv.value().size() + m_config.particles.size() > m_options.maxParticles) {
      badValue(f.child("file"), "the file has " + std::to_string(csv.value().size()) + " particles; the limit is " +
                                    std::to_string(m_options.maxParticles) + " in all",
               file->loc);
      return false;
    }
    out.position = csv.value().position;
    out.radius = csv.value().radius;
    vel = csv.value().velocity.value_or(std::vector<Vec3d>(out.size(), v0));
    spin = csv.value().angularVelocity.value_or(std::vector<Vec3d>(out.size(), w0));
    return true;
  }
  const std::string path = f.child("list");
  if (!isList(list->value, path, list->loc, "particles ({position: [x, y, z], radius: r, ...})")) return false;
  set.inlineList = true;
  for (std::size_t j = 0; j < list->value.size(); ++j) {
    const YAML::Node item = list->value[j];
    const std::string ip = at(path, j);
    const Loc itemLoc = locOf(item, list->loc);
    // Particles are kept even when an entry is broken, so indices in validate()'s messages stay aligned; the
    // broken fields are in m_badPaths and validate()'s findings about them are dropped.
    Vec3d x{0, 0, 0}, v = v0, w = w0;
    double r = 0;
    if (const auto pf = mapping(item, ip, list->loc, kParticleKeys)) {
      get(*pf, "position", x, true);
      get(*pf, "radius", r, true);
      get(*pf, "velocity", v);
      get(*pf, "angular_velocity", w);
    }
    if (m_config.particles.size() + out.size() >= m_options.maxParticles) {
      badValue(ip, "too many particles (the limit is " + std::to_string(m_options.maxParticles) + ")", itemLoc);
      return false;
    }
    out.position.push_back(x);
    out.radius.push_back(r);
    vel.push_back(v);
    spin.push_back(w);
    set.entryLocs.push_back(itemLoc);
  }
  return true;
}

void Loader::parseParticleSet(const YAML::Node& item, const std::string& path, Loc loc, std::size_t setIndex) {
  const auto f = mapping(item, path, loc, kParticleSetKeys);
  if (!f) return;
  const std::size_t errorsBefore = m_errors.size();
  std::string name = "set" + std::to_string(setIndex);
  get(*f, "name", name);
  const int material = materialRef(*f, "material");

  std::string method;
  if (const Entry* m = f->find("method")) {
    if (read(m->value, f->child("method"), m->loc, method) &&
        std::find(std::begin(kMethods), std::end(kMethods), method) == std::end(kMethods)) {
      badValue(f->child("method"), unknownName("method", method, kMethods, "Methods"), m->loc);
      method.clear();
    }
  } else if (f->find("list") || f->find("file")) {
    method = "list";
  } else {
    missing(*f, "method", joinNames(kMethods));
  }
  if (method.empty()) return;

  // Keys that make no sense for this method are errors rather than silently ignored.
  auto notFor = [&](std::string_view key, const std::string& why) {
    if (const Entry* k = f->find(key)) badValue(f->child(key), "'" + std::string(key) + "' " + why, k->keyLoc);
  };
  for (std::string_view opt : {"lattice", "tiled", "random"})
    if (opt != method) notFor(opt, "options apply to method " + std::string(opt) + ", and this set's method is " + method);
  if (method != "list") {
    notFor("list", "gives explicit particles: use method list");
    notFor("file", "gives explicit particles from a CSV file: use method list");
  } else {
    for (std::string_view key : {"size", "count", "solid_fraction"}) notFor(key, "applies to generated sets (lattice, random, tiled), not to method list");
  }
  if (method == "lattice") notFor("solid_fraction", "does not apply to a lattice, whose spacing sets the density; use 'count' to cap it");
  const Vec3d v0 = readVec(*f, "velocity").value_or(Vec3d{0, 0, 0});
  const Vec3d w0 = readVec(*f, "angular_velocity").value_or(Vec3d{0, 0, 0});

  ParticleSet set;
  set.first = m_config.particles.size();
  set.path = path;
  set.method = method;
  Particles made;
  std::vector<Vec3d> vel, spin;
  double regionVolume = 0;

  if (method == "list") {
    if (!parseParticleList(*f, v0, w0, made, vel, spin, set)) return;
    const Entry* r = f->find("region");
    if (r) {
      auto region = parseParticleRegion(*f);
      if (!region) return;
      regionVolume = std::fabs(region->volume());
      if (m_errors.size() == errorsBefore) {
        auto checked = generateList(made, {}, &*region);
        if (!checked) badValue(f->child("region"), checked.status().message(), r->loc);
      }
    }
  } else {
    auto size = parseSize(*f);
    auto region = parseParticleRegion(*f);
    std::optional<std::size_t> count;
    std::optional<double> fraction;
    if (const Entry* c = f->find("count")) {
      long long n = 0;
      const auto v = parseInteger(c->value);
      if (!v || *v < 1) badValue(f->child("count"), "expected an integer >= 1, got " + describe(c->value), c->loc);
      else n = *v;
      if (n > 0) {
        if (static_cast<std::size_t>(n) + m_config.particles.size() > m_options.maxParticles)
          badValue(f->child("count"), std::to_string(n) + " particles would exceed the limit of " + std::to_string(m_options.maxParticles) + " in all", c->loc);
        else count = static_cast<std::size_t>(n);
      }
    }
    if (const Entry* s = f->find("solid_fraction"); s && method != "lattice") {
      double phi = 0;
      if (read(s->value, f->child("solid_fraction"), s->loc, phi)) {
        if (!(phi > 0 && phi < 0.74)) badValue(f->child("solid_fraction"), num(phi) + " is outside (0, 0.74) (0.74 is the densest packing of equal spheres)", s->loc);
        else fraction = phi;
      }
    }
    if (method != "lattice" && f->find("count") && f->find("solid_fraction"))
      badValue(path, "give either 'count' or 'solid_fraction', not both", f->loc);
    if (method == "random" && !f->find("count") && !f->find("solid_fraction"))
      missing(*f, "count", "or 'solid_fraction': how many particles to insert");

    // Method options.
    LatticeOptions lattice;
    RandomOptions random;
    TiledOptions tiled;
    lattice.count = count;
    lattice.maxSites = m_options.maxLatticeSites;
    random.count = count;
    random.solidFraction = fraction;
    tiled.count = count;
    tiled.solidFraction = fraction;
    auto attempts = [&](const Fields& of, std::size_t& out) {
      if (const Entry* a = of.find("max_attempts")) {
        int n = 0;
        if (read(a->value, of.child("max_attempts"), a->loc, n)) {
          if (n < 1) badValue(of.child("max_attempts"), std::to_string(n) + " must be >= 1", a->loc);
          else out = static_cast<std::size_t>(n);
        }
      }
    };
    if (const Entry* o = f->find(method); o && method == "lattice") {
      if (const auto lf = mapping(o->value, f->child("lattice"), o->loc, kLatticeKeys)) {
        if (const Entry* p = lf->find("packing")) {
          std::string packing;
          if (read(p->value, lf->child("packing"), p->loc, packing)) {
            if (packing == "hexagonal") lattice.packing = LatticeOptions::Packing::kHexagonalClosePacked;
            else if (packing != "cubic") badValue(lf->child("packing"), unknownName("packing", packing, kPackings, "Choices"), p->loc);
          }
        }
        if (lf->find("spacing")) positive(*lf, "spacing", lattice.spacing, false);
        if (lf->find("jitter")) positive(*lf, "jitter", lattice.jitter, false, true);
      }
    } else if (o && method == "random") {
      if (const auto rf = mapping(o->value, f->child("random"), o->loc, kRandomKeys)) attempts(*rf, random.maxAttemptsPerParticle);
    } else if (o && method == "tiled") {
      if (const auto tf = mapping(o->value, f->child("tiled"), o->loc, kTiledKeys)) {
        if (tf->find("tile_size")) positive(*tf, "tile_size", tiled.tileEdge, false);
        attempts(*tf, tiled.maxAttemptsPerParticle);
      }
    }
    if (!size || !region || m_errors.size() != errorsBefore) return;
    // The generator's own checks, each reported at the scene key it comes from ("lattice.jitter" ->
    // particles[i].lattice.jitter, "random.count" -> particles[i].count, "tiled.tile_edge" -> particles[i].tiled.tile_size).
    const ErrorList inputErrors = method == "lattice" ? checkLattice(*size, lattice)
                                  : method == "random" ? checkRandom(*size, random)
                                                       : checkTiled(*size, tiled);
    for (const FieldError& fe : inputErrors.errors()) {
      std::string key = fe.path.substr(std::min(fe.path.size(), method.size() + 1));
      if (key == "tile_edge") key = "tiled.tile_size";
      else if (key == "spacing" || key == "jitter" || key == "packing" || key == "max_attempts") key = method + "." + key;
      const std::string p = key.empty() ? path : f->child(key);
      badValue(p, fe.message, markFor(p));
    }
    if (!inputErrors.empty()) return;
    regionVolume = std::fabs(region->volume());
    if (fraction && regionVolume * *fraction / size->meanVolume() + double(m_config.particles.size()) > double(m_options.maxParticles)) {
      badValue(f->child("solid_fraction"), "would make about " + num(regionVolume * *fraction / size->meanVolume()) + " particles; the limit is " +
                                               std::to_string(m_options.maxParticles) + " in all",
               f->find("solid_fraction")->loc);
      return;
    }
    // A tiled set without a count or a solid fraction fills the region at the tile's default fraction: refuse before
    // generating when that would pass the limit (millions of particles are made before they could be counted).
    if (method == "tiled" && !tiled.count && !fraction) {
      const double estimate = regionVolume * TiledOptions::kDefaultTileSolidFraction / size->meanVolume();
      if (estimate + double(m_config.particles.size()) > double(m_options.maxParticles)) {
        badValue(path, "fills its region with about " + num(estimate) + " particles (the tile's solid fraction " +
                           num(TiledOptions::kDefaultTileSolidFraction) + "); the limit is " + std::to_string(m_options.maxParticles) +
                           " in all (give a count, a solid_fraction or a smaller region)",
                 f->loc);
        return;
      }
    }
    // A lattice without a count fills the region: refuse before generating when that would pass the limit
    // (the sites are tested one by one against the region and the walls, which takes long for millions).
    if (method == "lattice" && !lattice.count) {
      const double spacing = lattice.spacing > 0 ? lattice.spacing : 2.1 * size->maxRadius();
      const bool hcp = lattice.packing == LatticeOptions::Packing::kHexagonalClosePacked;
      const double sites = regionVolume / (spacing * spacing * spacing * (hcp ? std::sqrt(0.5) : 1.0));
      if (sites + double(m_config.particles.size()) > double(m_options.maxParticles)) {
        badValue(path, "fills its region with about " + num(sites) + " lattice particles; the limit is " +
                           std::to_string(m_options.maxParticles) + " in all (give a count or a larger spacing)",
                 f->loc);
        return;
      }
    }

    // Keep clear of earlier sets and of every wall.
    if (!m_clearance) m_clearance = std::make_shared<WallClearance>(m_config.planes, m_config.meshes);  // walls are final here
    const auto clearance = m_clearance;
    Avoid avoid;
    avoid.position = m_config.particles.position;
    avoid.radius = m_config.particles.radius;
    if (!clearance->empty()) avoid.reject = [clearance](const Vec3d& c, double r) { return clearance->touches(c, r); };
    const std::uint64_t seed = streamSeed(m_config.sim.seed, setIndex);
    Result<Particles> result = method == "lattice" ? generateLattice(*region, *size, lattice, seed, avoid)
                               : method == "random" ? generateRandom(*region, *size, random, seed, avoid)
                                                    : generateTiled(*region, *size, tiled, seed, avoid);
    if (!result) {
      badValue(path, result.status().message(), f->loc);
      return;
    }
    made = std::move(result).value();
    if (made.size() + m_config.particles.size() > m_options.maxParticles) {
      badValue(path, "made " + std::to_string(made.size()) + " particles; the limit is " + std::to_string(m_options.maxParticles) + " in all", f->loc);
      return;
    }
    if (made.size() == 0) {
      badValue(f->child("region"), "no particle fits: the region is too small for the particle size, or walls or earlier particles fill it", f->loc);
      return;
    }
    vel.assign(made.size(), v0);
    spin.assign(made.size(), w0);
  }

  ParticleSetInfo info;
  info.name = name;
  info.method = method;
  info.first = m_config.particles.size();
  info.count = made.size();
  info.regionVolume = regionVolume;
  info.minRadius = made.size() ? *std::min_element(made.radius.begin(), made.radius.end()) : 0;
  info.maxRadius = made.size() ? *std::max_element(made.radius.begin(), made.radius.end()) : 0;
  for (double r : made.radius) info.solidVolume += 4.0 / 3.0 * std::numbers::pi * r * r * r;
  compute::ParticleInit& p = m_config.particles;
  p.position.reserve(p.size() + made.size());
  p.radius.reserve(p.size() + made.size());
  p.material.reserve(p.size() + made.size());
  for (std::size_t k = 0; k < made.size(); ++k) addParticle(made.position[k], made.radius[k], vel[k], spin[k], material);
  set.count = made.size();
  if (set.count > 0) m_sets.push_back(std::move(set));
  m_setInfo.push_back(std::move(info));
}

void Loader::parseParticles(const Fields& top) {
  const Entry* e = top.find("particles");
  if (!e || !isList(e->value, "particles", e->loc, "particle sets")) return;
  for (std::size_t s = 0; s < e->value.size(); ++s) {
    const std::string path = at("particles", s);
    const Loc itemLoc = locOf(e->value[s], e->loc);
    m_marks[path] = itemLoc;
    parseParticleSet(e->value[s], path, e->loc, s);
  }
  compute::ParticleInit& p = m_config.particles;
  if (!p.velocity.empty()) p.velocity.resize(p.size(), Vec3d{0, 0, 0});
  if (!p.angularVelocity.empty()) p.angularVelocity.resize(p.size(), Vec3d{0, 0, 0});
}

}  // namespace pflow::frontend::detail
