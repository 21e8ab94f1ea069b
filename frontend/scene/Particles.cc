#include "frontend/scene/Loader.h"
#include <random>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "compute/core/Format.h"

namespace pflow::frontend::detail {

using format::at;
using format::num;
using format::vec;

std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Uniform in [-1, 1), the same on every standard library (std::uniform_real_distribution is not).
double symmetricUniform(std::mt19937_64& rng) { return 2.0 * static_cast<double>(rng() >> 11) * 0x1.0p-53 - 1.0; }

// Number of lattice sites along an edge of length `length`: centres at r, r + s, ... up to length - r.
std::size_t sitesAlong(double length, double radius, double spacing) {
  if (!(length >= 2 * radius)) return 0;
  return static_cast<std::size_t>(std::floor((length - 2 * radius) / spacing + 1e-9)) + 1;
}

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

void Loader::parseParticles(const Fields& top) {
  const Entry* e = top.find("particles");
  if (!e || !isList(e->value, "particles", e->loc, "particle sets (each with 'list' or 'lattice')")) return;
  std::size_t s = 0;
  for (const YAML::Node& item : e->value) {
    const std::size_t setIndex = s++;
    const std::string path = at("particles", setIndex);
    const Loc itemLoc = locOf(item, e->loc);
    m_marks[path] = itemLoc;
    const auto f = mapping(item, path, e->loc, kParticleSetKeys);
    if (!f) continue;
    const int material = materialRef(*f, "material");
    const Entry* list = f->find("list");
    const Entry* lattice = f->find("lattice");
    if ((list != nullptr) == (lattice != nullptr)) {
      badValue(path, list ? "give either 'list' or 'lattice', not both (use two particle sets)" : "expected 'list' (explicit particles) or 'lattice' (a packed region)",
               itemLoc);
      continue;
    }
    ParticleSet set;
    set.first = m_config.particles.size();
    set.path = path;
    set.lattice = lattice != nullptr;
    if (list) {
      parseParticleList(list->value, f->child("list"), list->loc, material, set);
    } else {
      parseLattice(lattice->value, f->child("lattice"), lattice->loc, material, setIndex);
    }
    set.count = m_config.particles.size() - set.first;
    if (set.count > 0) m_sets.push_back(std::move(set));
  }
  compute::ParticleInit& p = m_config.particles;
  if (!p.velocity.empty()) p.velocity.resize(p.size(), Vec3d{0, 0, 0});
  if (!p.angularVelocity.empty()) p.angularVelocity.resize(p.size(), Vec3d{0, 0, 0});
}

void Loader::parseParticleList(const YAML::Node& list, const std::string& path, Loc loc, int material, ParticleSet& set) {
  if (!isList(list, path, loc, "particles ({position: [x, y, z], radius: r, ...})")) return;
  std::size_t j = 0;
  for (const YAML::Node& item : list) {
    const std::string ip = at(path, j++);
    const Loc itemLoc = locOf(item, loc);
    // Particles are pushed even when an entry is broken, so indices in validate()'s messages stay aligned; the
    // broken fields are in m_badPaths and validate()'s findings about them are dropped.
    Vec3d x{0, 0, 0}, v{0, 0, 0}, w{0, 0, 0};
    double r = 0;
    if (const auto f = mapping(item, ip, loc, kParticleKeys)) {
      get(*f, "position", x, true);
      get(*f, "radius", r, true);
      get(*f, "velocity", v);
      get(*f, "angular_velocity", w);
    }
    if (m_config.particles.size() >= m_options.maxParticles) {
      badValue(ip, "too many particles (the limit is " + std::to_string(m_options.maxParticles) + ")", itemLoc);
      return;
    }
    addParticle(x, r, v, w, material);
    set.entryLocs.push_back(itemLoc);
  }
}

void Loader::parseLattice(const YAML::Node& node, const std::string& path, Loc loc, int material, std::size_t setIndex) {
  const auto f = mapping(node, path, loc, kLatticeKeys);
  if (!f) return;
  Vec3d lo{0, 0, 0}, hi{0, 0, 0}, velocity{0, 0, 0};
  double radius = 0, spacing = 0, jitter = kDefaultJitter;
  int count = 0;
  const std::size_t before = m_errors.size();
  const bool haveBox = parseRegion(*f, "box", lo, hi, true);
  const bool haveRadius = get(*f, "radius", radius, true);
  const bool haveSpacing = get(*f, "spacing", spacing);
  get(*f, "jitter", jitter);
  get(*f, "velocity", velocity);
  const bool haveCount = get(*f, "count", count);
  if (m_errors.size() != before) return;  // a missing or mistyped key: nothing sensible to generate

  bool ok = true;
  auto bad = [&](std::string_view key, const std::string& message) {
    badValue(f->child(key), message, f->find(key) ? f->find(key)->loc : f->loc);
    ok = false;
  };
  if (!isFinite(lo) || !isFinite(hi) || !(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z)) {
    bad("box", "max " + vec(hi) + " must be > min " + vec(lo) + " on every axis");
  }
  if (!haveRadius || !std::isfinite(radius) || !(radius > 0)) bad("radius", num(radius) + " must be > 0");
  if (!haveSpacing) spacing = kDefaultSpacingFactor * radius;
  if (ok && (!std::isfinite(spacing) || !(spacing >= 2 * radius))) {
    bad("spacing", num(spacing) + " must be >= the diameter " + num(2 * radius) + " (centre-to-centre distance)");
  }
  if (!std::isfinite(jitter) || !(jitter >= 0)) {
    bad("jitter", num(jitter) + " must be >= 0");
  } else if (ok) {
    // Neighbours on the lattice stay apart when 2 * jitter * radius <= spacing - 2 * radius.
    const double maxJitter = (spacing - 2 * radius) / (2 * radius);
    if (jitter > maxJitter * (1 + 1e-12)) {
      bad("jitter", num(jitter) + " lets neighbouring particles overlap: with spacing " + num(spacing) + " and radius " + num(radius) +
                        " it must be <= " + num(maxJitter));
    }
  }
  if (haveCount && count < 1) bad("count", std::to_string(count) + " must be >= 1");
  if (!ok || !haveBox) return;

  const Vec3d size = hi - lo;
  const std::size_t nx = sitesAlong(size.x, radius, spacing), ny = sitesAlong(size.y, radius, spacing), nz = sitesAlong(size.z, radius, spacing);
  const double sites = static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz);
  if (sites == 0) {
    bad("box", "the box " + vec(lo) + " - " + vec(hi) + " is too small to hold one sphere of radius " + num(radius));
    return;
  }
  if (haveCount && static_cast<double>(count) > sites) {
    bad("count", std::to_string(count) + " is more than the " + num(sites) + " lattice sites that fit in the box (" + std::to_string(nx) + " x " +
                     std::to_string(ny) + " x " + std::to_string(nz) + ")");
    return;
  }
  const double wanted = haveCount ? static_cast<double>(count) : sites;
  if (wanted + static_cast<double>(m_config.particles.size()) > static_cast<double>(m_options.maxParticles)) {
    badValue(path, "would generate " + num(wanted) + " particles; the limit is " + std::to_string(m_options.maxParticles) + " in all (set 'count' or a larger spacing)",
             f->loc);
    return;
  }
  const auto target = static_cast<std::size_t>(wanted);
  m_config.particles.position.reserve(m_config.particles.size() + target);
  m_config.particles.radius.reserve(m_config.particles.size() + target);
  m_config.particles.material.reserve(m_config.particles.size() + target);

  std::mt19937_64 rng(splitMix64(m_config.sim.seed ^ splitMix64(static_cast<std::uint64_t>(setIndex))));
  const double amplitude = jitter * radius;
  const Vec3d cmin = lo + Vec3d{radius, radius, radius}, cmax = hi - Vec3d{radius, radius, radius};
  std::size_t made = 0;
  // x fastest, then y, then z: a count cap fills the lowest layers first.
  for (std::size_t iz = 0; iz < nz && made < target; ++iz) {
    for (std::size_t iy = 0; iy < ny && made < target; ++iy) {
      for (std::size_t ix = 0; ix < nx && made < target; ++ix, ++made) {
        const Vec3d site = cmin + Vec3d{static_cast<double>(ix) * spacing, static_cast<double>(iy) * spacing, static_cast<double>(iz) * spacing};
        Vec3d x{site.x + amplitude * symmetricUniform(rng), site.y + amplitude * symmetricUniform(rng), site.z + amplitude * symmetricUniform(rng)};
        // Clamping keeps every sphere inside the box; it only moves a centre back towards its site.
        x = {std::clamp(x.x, cmin.x, cmax.x), std::clamp(x.y, cmin.y, cmax.y), std::clamp(x.z, cmin.z, cmax.z)};
        addParticle(x, radius, velocity, Vec3d{0, 0, 0}, material);
      }
    }
  }
}

}  // namespace pflow::frontend::detail
