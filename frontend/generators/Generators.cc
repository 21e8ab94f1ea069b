#include "frontend/generators/Generators.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <sstream>

namespace pflow::frontend {
namespace {

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

Status exhausted(std::string message) { return {StatusCode::kResourceExhausted, std::move(message)}; }

double sphereVolume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

double comp(const Vec3d& v, int a) { return a == 0 ? v.x : a == 1 ? v.y : v.z; }

// ---- a uniform cell grid of spheres -------------------------------------------------------------------------------
//
// Cells are at least `minCell` wide, so two spheres closer than minCell lie in the same or adjacent cells.
// Non-periodic grids cover `bounds`; points outside map to the nearest boundary cell (clamping never separates
// two points closer than a cell). Periodic grids cover the cube [0, L)^3 and compare by minimum image.
class SphereGrid {
 public:
  struct Sphere {
    Vec3d c;
    double r;
  };

  SphereGrid(const Bounds& bounds, double minCell, std::size_t expected) : m_origin(bounds.min) {
    const Vec3d s = bounds.size();
    const double cap = std::max(double(1 << 20), 4.0 * static_cast<double>(expected));
    double h = minCell;
    // Coarsen until the grid has at most `cap` cells.
    for (;;) {
      double cells = 1;
      for (int a = 0; a < 3; ++a) cells *= std::max(1.0, std::ceil(comp(s, a) / h));
      if (cells <= cap) break;
      h *= 1.25;
    }
    for (int a = 0; a < 3; ++a) m_n[a] = static_cast<int>(std::max(1.0, std::ceil(comp(s, a) / h)));
    m_h = h;
    m_inv = 1.0 / h;
    m_head.assign(static_cast<std::size_t>(m_n[0]) * m_n[1] * m_n[2], -1);
  }

  static SphereGrid periodic(double edge, double minCell) {
    SphereGrid g(Bounds{{0, 0, 0}, {edge, edge, edge}}, minCell, 0);
    g.m_periodic = true;
    g.m_edge = edge;
    const int n = std::max(1, static_cast<int>(std::floor(edge / minCell)));  // cells at least minCell wide
    g.m_n = {n, n, n};
    g.m_h = edge / n;
    g.m_inv = n / edge;
    g.m_head.assign(static_cast<std::size_t>(n) * n * n, -1);
    return g;
  }

  void insert(const Vec3d& c, double r, std::size_t id) {
    const std::size_t cell = cellOf(c);
    m_spheres.push_back({c, r});
    m_ids.push_back(id);
    m_next.push_back(m_head[cell]);
    m_head[cell] = static_cast<std::int32_t>(m_spheres.size() - 1);
  }

  // Minimum image of a - b (periodic) or a - b.
  Vec3d delta(const Vec3d& a, const Vec3d& b) const {
    Vec3d d = a - b;
    if (m_periodic) {
      d.x -= m_edge * std::nearbyint(d.x / m_edge);
      d.y -= m_edge * std::nearbyint(d.y / m_edge);
      d.z -= m_edge * std::nearbyint(d.z / m_edge);
    }
    return d;
  }

  // Calls f(sphere, id) for the spheres in p's cell and its neighbours until f returns true; returns whether it did.
  template <class F>
  bool anyNear(const Vec3d& p, F&& f) const {
    std::array<int, 3> k = coords(p);
    std::array<int, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a) {
      if (m_periodic) {
        lo[a] = m_n[a] >= 3 ? -1 : 0;
        hi[a] = m_n[a] >= 3 ? 1 : m_n[a] - 1;
      } else {
        lo[a] = k[a] > 0 ? -1 : 0;
        hi[a] = k[a] < m_n[a] - 1 ? 1 : 0;
      }
    }
    for (int dz = lo[2]; dz <= hi[2]; ++dz) {
      const int z = wrap(k[2] + dz, 2);
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        const int y = wrap(k[1] + dy, 1);
        for (int dx = lo[0]; dx <= hi[0]; ++dx) {
          const int x = wrap(k[0] + dx, 0);
          for (std::int32_t s = m_head[(static_cast<std::size_t>(z) * m_n[1] + y) * m_n[0] + x]; s >= 0; s = m_next[s]) {
            if (f(m_spheres[s], m_ids[s])) return true;
          }
        }
      }
    }
    return false;
  }

  // True when a stored sphere is closer than r + its radius to p (touching is not overlapping).
  bool overlaps(const Vec3d& p, double r) const {
    return anyNear(p, [&](const Sphere& s, std::size_t) {
      const double reach = r + s.r;
      return norm2(delta(p, s.c)) < reach * reach;
    });
  }

  double cellSize() const { return m_h; }

 private:
  std::array<int, 3> coords(const Vec3d& p) const {
    std::array<int, 3> k{};
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor((comp(p, a) - comp(m_origin, a)) * m_inv);
      const double top = m_n[a] - 1;
      if (m_periodic) {
        const double w = f - m_n[a] * std::floor(f / m_n[a]);
        k[a] = static_cast<int>(std::clamp(w, 0.0, top));
      } else {
        k[a] = static_cast<int>(std::clamp(f, 0.0, top));
      }
    }
    return k;
  }
  std::size_t cellOf(const Vec3d& p) const {
    const auto k = coords(p);
    return (static_cast<std::size_t>(k[2]) * m_n[1] + k[1]) * m_n[0] + k[0];
  }
  int wrap(int i, int a) const {
    if (!m_periodic) return i;
    return i < 0 ? i + m_n[a] : i >= m_n[a] ? i - m_n[a] : i;
  }

  Vec3d m_origin;
  std::array<int, 3> m_n{1, 1, 1};
  double m_h = 1, m_inv = 1;
  bool m_periodic = false;
  double m_edge = 0;
  std::vector<std::int32_t> m_head, m_next;
  std::vector<Sphere> m_spheres;
  std::vector<std::size_t> m_ids;
};

double maxOf(std::span<const double> v) {
  double m = 0;
  for (double x : v) m = std::max(m, x);
  return m;
}

// Existing spheres in a grid over `bounds` for new spheres up to radius rNew; only those that can reach the bounds.
SphereGrid existingGrid(const Bounds& bounds, double rNew, const Avoid& avoid, std::size_t expected) {
  const double rOld = maxOf(avoid.radius);
  const double reach = rNew + std::max(rNew, rOld);
  SphereGrid grid(bounds, reach, expected);
  const Vec3d lo = bounds.min - Vec3d{reach, reach, reach}, hi = bounds.max + Vec3d{reach, reach, reach};
  for (std::size_t i = 0; i < avoid.position.size(); ++i) {
    const Vec3d& p = avoid.position[i];
    if (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z) grid.insert(p, avoid.radius[i], i);
  }
  return grid;
}

void validateAvoid(const Avoid& avoid, ErrorList& e) {
  if (avoid.position.size() != avoid.radius.size()) {
    e.add("existing", std::to_string(avoid.position.size()) + " positions but " + std::to_string(avoid.radius.size()) + " radii");
    return;
  }
  for (std::size_t i = 0; i < avoid.radius.size(); ++i) {
    if (!isFinite(avoid.position[i]) || !std::isfinite(avoid.radius[i]) || !(avoid.radius[i] >= 0)) {
      e.add("existing[" + std::to_string(i) + "]", "position and radius must be finite and radius >= 0");
      return;
    }
  }
}

// ---- free space: where a new centre may still go ------------------------------------------------------------------
//
// The sampling box (centres of the smallest radius) is cut into blocks of 4 x 4 x 4 voxels, one bit per voxel.
// Trial centres are uniform over the voxels still marked free: a random block from the list of blocks with a free
// voxel, a random voxel of it (redrawn until free), a uniform point in the voxel. When a trial is blocked by a
// sphere that covers the whole voxel (its farthest corner closer than the sphere's radius plus the smallest
// radius still to place), the voxel can never take a centre again and is cleared. Trials therefore stay uniform
// over every place a centre could go, and they concentrate on the remaining holes as the packing fills up, instead
// of slowing down like plain uniform trials near jamming.
class FreeSpace {
 public:
  struct Voxel {
    std::uint32_t block;
    int bit;
  };

  FreeSpace(const Bounds& box, double rSmall, std::size_t expected) : m_box(box), m_rSmall(rSmall) {
    const Vec3d s = box.size();
    const double cap = std::max(double(1 << 18), 2.0 * static_cast<double>(expected));
    double edge = 2 * rSmall;
    for (;;) {
      double blocks = 1;
      for (int a = 0; a < 3; ++a) blocks *= std::max(1.0, std::ceil(comp(s, a) / edge));
      if (blocks <= cap) break;
      edge *= 1.25;
    }
    for (int a = 0; a < 3; ++a) {
      m_n[a] = static_cast<std::uint32_t>(std::max(1.0, std::ceil(comp(s, a) / edge)));
      m_voxel[a] = comp(s, a) / (4.0 * m_n[a]);
    }
    const std::size_t count = static_cast<std::size_t>(m_n[0]) * m_n[1] * m_n[2];
    m_mask.assign(count, ~std::uint64_t{0});
    m_active.resize(count);
    m_slot.resize(count);
    for (std::size_t i = 0; i < count; ++i) m_active[i] = m_slot[i] = static_cast<std::uint32_t>(i);
  }

  bool empty() const { return m_active.empty(); }

  Vec3d propose(Random& rng, Voxel& v) const {
    v.block = m_active[rng.below(m_active.size())];
    const std::uint64_t mask = m_mask[v.block];
    do {
      v.bit = static_cast<int>(rng.bits() >> 58);
    } while (!((mask >> v.bit) & 1u));
    const Vec3d lo = corner(v);
    const double u = rng.uniform(), w = rng.uniform(), t = rng.uniform();
    return {lo.x + u * m_voxel[0], lo.y + w * m_voxel[1], lo.z + t * m_voxel[2]};
  }

  // A sphere (c, r) was placed: clear every voxel it excludes entirely, i.e. whose farthest corner is closer to c
  // than r plus the smallest radius still to place. `periodic`: the box is a periodic cube starting at the origin.
  void cover(const Vec3d& c, double r, bool periodic) {
    const double reach = r + m_rSmall;
    std::array<long, 3> lo{}, hi{}, n{};
    for (int a = 0; a < 3; ++a) {
      n[a] = 4L * m_n[a];
      const double o = comp(m_box.min, a), x = comp(c, a);
      lo[a] = static_cast<long>(std::floor((x - reach - o) / m_voxel[a]));
      hi[a] = static_cast<long>(std::floor((x + reach - o) / m_voxel[a]));
      if (periodic) {
        if (hi[a] - lo[a] + 1 > n[a]) hi[a] = lo[a] + n[a] - 1;
      } else {
        lo[a] = std::max(lo[a], 0L);
        hi[a] = std::min(hi[a], n[a] - 1);
      }
    }
    const double r2 = reach * reach;
    for (long z = lo[2]; z <= hi[2]; ++z) {
      const double dz = farthest(c.z, z, 2);
      const long wz = periodic ? ((z % n[2]) + n[2]) % n[2] : z;
      for (long y = lo[1]; y <= hi[1]; ++y) {
        const double dy = farthest(c.y, y, 1);
        const long wy = periodic ? ((y % n[1]) + n[1]) % n[1] : y;
        if (dz * dz + dy * dy >= r2) continue;
        for (long x = lo[0]; x <= hi[0]; ++x) {
          const double dx = farthest(c.x, x, 0);
          if (dx * dx + dy * dy + dz * dz >= r2) continue;
          const long wx = periodic ? ((x % n[0]) + n[0]) % n[0] : x;
          const std::uint32_t block = static_cast<std::uint32_t>((wz / 4 * m_n[1] + wy / 4) * m_n[0] + wx / 4);
          const int bit = static_cast<int>((wz % 4) * 16 + (wy % 4) * 4 + wx % 4);
          if ((m_mask[block] >> bit) & 1u) clear({block, bit});
        }
      }
    }
  }

  void clear(const Voxel& v) {
    std::uint64_t& mask = m_mask[v.block];
    mask &= ~(std::uint64_t{1} << v.bit);
    if (mask != 0) return;
    // Swap-remove the block from the active list.
    const std::uint32_t slot = m_slot[v.block], last = m_active.back();
    m_active[slot] = last;
    m_slot[last] = slot;
    m_active.pop_back();
  }

 private:
  // Largest distance along axis a from coordinate x to voxel i of the (unwrapped) lattice.
  double farthest(double x, long i, int a) const {
    const double lo = comp(m_box.min, a) + static_cast<double>(i) * m_voxel[a];
    return std::max(std::fabs(x - lo), std::fabs(lo + m_voxel[a] - x));
  }
  Vec3d corner(const Voxel& v) const {
    const std::uint32_t bx = v.block % m_n[0], by = (v.block / m_n[0]) % m_n[1], bz = v.block / (m_n[0] * m_n[1]);
    const int vx = v.bit & 3, vy = (v.bit >> 2) & 3, vz = v.bit >> 4;
    return {m_box.min.x + (4.0 * bx + vx) * m_voxel[0], m_box.min.y + (4.0 * by + vy) * m_voxel[1], m_box.min.z + (4.0 * bz + vz) * m_voxel[2]};
  }

  Bounds m_box;
  double m_rSmall;
  std::array<std::uint32_t, 3> m_n{1, 1, 1};
  std::array<double, 3> m_voxel{1, 1, 1};
  std::vector<std::uint64_t> m_mask;
  std::vector<std::uint32_t> m_active, m_slot;
};

// Random sequential addition of `radii`, in order. Each particle draws up to maxAttempts trial centres from
// `space`; a trial must lie in its own sampling box (centres of its radius), clear the spheres in `grid`, and pass
// accept(p, r) (region, reject rule). Stops at the first particle that finds no place.
struct RsaOutcome {
  std::size_t placed = 0;
  std::uint64_t attempts = 0;
  bool complete = false;
  bool saturated = false;  // no free voxel left at all
  double placedVolume = 0;
};

template <class Accept, class Place>
RsaOutcome sequentialAddition(const std::vector<double>& radii, std::size_t maxAttempts, const Bounds& box, bool periodic, SphereGrid& grid,
                              FreeSpace& space, Random& rng, Accept&& accept, Place&& place) {
  RsaOutcome out;
  for (const double r : radii) {
    // Centres of this radius (non-periodic: the box shrunk by r - the smallest radius, relative to the space).
    const double shrink = periodic ? 0.0 : r - radii.back();
    const Vec3d lo = box.min + Vec3d{shrink, shrink, shrink}, hi = box.max - Vec3d{shrink, shrink, shrink};
    bool done = false;
    for (std::size_t a = 0; a < maxAttempts && !done; ++a) {
      if (space.empty()) {
        out.saturated = true;
        return out;
      }
      ++out.attempts;
      FreeSpace::Voxel v;
      const Vec3d p = space.propose(rng, v);
      if (p.x < lo.x || p.x > hi.x || p.y < lo.y || p.y > hi.y || p.z < lo.z || p.z > hi.z) continue;
      if (grid.overlaps(p, r)) continue;
      if (!accept(p, r)) continue;
      place(p, r);
      grid.insert(p, r, out.placed);
      space.cover(p, r, periodic);
      out.placedVolume += sphereVolume(r);
      done = true;
    }
    if (!done) return out;
    ++out.placed;
  }
  out.complete = true;
  return out;
}

std::string failureReport(const RsaOutcome& o, const std::vector<double>& radii, std::size_t maxAttempts) {
  const std::string which = "particle " + std::to_string(o.placed + 1) + " of " + std::to_string(radii.size()) + " (radius " + num(radii[o.placed]) + ")";
  const std::string why = o.saturated ? " found no free space left" : " found no free place in " + std::to_string(maxAttempts) + " attempts";
  return which + why + "; placed " + std::to_string(o.placed) + " particles after " + std::to_string(o.attempts) + " attempts in all";
}

// Radii for a request: `count` draws, or draws until their volume reaches `volume`; sorted largest first.
std::vector<double> drawRadii(const SizeDistribution& size, std::optional<std::size_t> count, double volume, Random& rng) {
  std::vector<double> radii;
  if (count) {
    radii.resize(*count);
    for (double& r : radii) r = size.sample(rng);
  } else {
    double total = 0;
    radii.reserve(static_cast<std::size_t>(volume / size.meanVolume() * 1.01) + 16);
    while (total < volume) {
      radii.push_back(size.sample(rng));
      total += sphereVolume(radii.back());
    }
  }
  std::stable_sort(radii.begin(), radii.end(), std::greater<>());
  return radii;
}

void validateFraction(const std::optional<std::size_t>& count, const std::optional<double>& fraction, const std::string& path, bool needOne, ErrorList& e) {
  if (needOne && count.has_value() == fraction.has_value()) e.add(path, "give exactly one of 'count' and 'solid_fraction'");
  if (count && *count < 1) e.add(path + ".count", "0 must be >= 1");
  if (fraction && !(std::isfinite(*fraction) && *fraction > 0 && *fraction < 0.7405)) {
    e.add(path + ".solid_fraction", num(*fraction) + " must be in (0, 0.7405): no packing of spheres is denser than 0.7405");
  }
}

std::string fractionReport(double placedVolume, double wantedVolume, double regionVolume) {
  return "solid fraction reached " + num(placedVolume / regionVolume) + " of the requested " + num(wantedVolume / regionVolume) +
         " (random sequential addition of equal spheres jams near 0.38)";
}

}  // namespace

// ---- lattice ------------------------------------------------------------------------------------------------------

double maxLatticeJitter(LatticeOptions::Packing packing, double spacing, double maxRadius) {
  const double gap = (spacing - 2 * maxRadius) / (2 * maxRadius);
  return packing == LatticeOptions::Packing::kSimpleCubic ? gap : gap / std::numbers::sqrt3;
}

ErrorList checkLattice(const SizeDistribution& size, const LatticeOptions& options, const Avoid& avoid) {
  ErrorList e = size.validate("lattice.size");
  validateAvoid(avoid, e);
  const double rmax = size.maxRadius();
  const double spacing = options.spacing > 0 ? options.spacing : 2.1 * rmax;
  const bool sizeOk = e.empty();
  if (!std::isfinite(options.spacing) || options.spacing < 0) {
    e.add("lattice.spacing", num(options.spacing) + " must be >= 0 (0: 2.1 x the largest radius)");
  } else if (sizeOk && !(spacing >= 2 * rmax)) {
    e.add("lattice.spacing", num(spacing) + " must be >= the largest diameter " + num(2 * rmax) + " (centre-to-centre distance)");
  }
  if (!std::isfinite(options.jitter) || !(options.jitter >= 0)) {
    e.add("lattice.jitter", num(options.jitter) + " must be >= 0");
  } else if (sizeOk && spacing >= 2 * rmax) {
    const double bound = maxLatticeJitter(options.packing, spacing, rmax);
    if (options.jitter > bound * (1 + 1e-12)) {
      e.add("lattice.jitter", num(options.jitter) + " lets neighbouring particles overlap: with spacing " + num(spacing) + " and largest radius " +
                                  num(rmax) + " it must be <= " + num(bound));
    }
  }
  if (options.count && *options.count < 1) e.add("lattice.count", "0 must be >= 1");
  return e;
}

Result<Particles> generateLattice(const Region& region, const SizeDistribution& size, const LatticeOptions& options, std::uint64_t seed,
                                  const Avoid& avoid) {
  if (ErrorList e = checkLattice(size, options, avoid); !e.empty()) return e.toStatus("lattice");
  const double rmax = size.maxRadius();
  const double spacing = options.spacing > 0 ? options.spacing : 2.1 * rmax;

  const Bounds b = region.bounds();
  const Vec3d cmin = b.min + Vec3d{rmax, rmax, rmax}, cmax = b.max - Vec3d{rmax, rmax, rmax};
  const bool hcp = options.packing == LatticeOptions::Packing::kHexagonalClosePacked;
  const double dx = spacing, dy = hcp ? spacing * std::numbers::sqrt3 / 2 : spacing, dz = hcp ? spacing * std::sqrt(6.0) / 3 : spacing;
  auto sitesAlong = [&](double length, double step) -> long {
    if (!(length >= 2 * rmax)) return 0;
    return static_cast<long>(std::floor((length - 2 * rmax) / step + 1e-9)) + 1;
  };
  const Vec3d s = b.size();
  const long nx = sitesAlong(s.x, dx), ny = sitesAlong(s.y, dy), nz = sitesAlong(s.z, dz);
  const bool box = region.kind() == Region::Kind::kBox;
  const double slack = 1e-9 * spacing;  // HCP's shifted rows may end a rounding error past the last site

  Random rng(seed);
  SphereGrid existing = existingGrid(b, rmax, avoid, 0);
  const bool haveExisting = !avoid.position.empty();
  Particles out;
  const std::size_t target = options.count.value_or(std::numeric_limits<std::size_t>::max());
  std::size_t usable = 0, visited = 0;
  // x fastest, then y, then z: a count cap fills the lowest layers first.
  for (long iz = 0; iz < nz && out.size() < target; ++iz) {
    for (long iy = 0; iy < ny && out.size() < target; ++iy) {
      for (long ix = 0; ix < nx && out.size() < target; ++ix) {
        Vec3d site;
        if (!hcp) {
          site = cmin + Vec3d{static_cast<double>(ix) * spacing, static_cast<double>(iy) * spacing, static_cast<double>(iz) * spacing};
        } else {
          const double shiftX = 0.5 * static_cast<double>((iy + iz) % 2), shiftY = static_cast<double>(iz % 2) / 3.0;
          site = cmin + Vec3d{(static_cast<double>(ix) + shiftX) * dx, (static_cast<double>(iy) + shiftY) * dy, static_cast<double>(iz) * dz};
          if (site.x > cmax.x + slack || site.y > cmax.y + slack || site.z > cmax.z + slack) continue;
        }
        if (++visited > options.maxSites) {
          return exhausted("lattice: visited " + std::to_string(options.maxSites) + " sites of the region's bounds (" + std::to_string(nx) + " x " +
                           std::to_string(ny) + " x " + std::to_string(nz) + ") and found " + std::to_string(out.size()) +
                           " particles; that is the loader's limit: use a larger spacing, a count the first layers hold, or a region whose bounds it fills");
        }
        if (!box && !region.containsSphere(site, rmax)) continue;
        ++usable;
        const double r = size.sample(rng);
        const double amplitude = options.jitter * r;
        Vec3d x{site.x + amplitude * rng.symmetric(), site.y + amplitude * rng.symmetric(), site.z + amplitude * rng.symmetric()};
        if (box) {
          // Clamping keeps the sphere inside the box and only moves a centre back towards its site.
          const Vec3d lo = b.min + Vec3d{r, r, r}, hi = b.max - Vec3d{r, r, r};
          x = {std::clamp(x.x, lo.x, hi.x), std::clamp(x.y, lo.y, hi.y), std::clamp(x.z, lo.z, hi.z)};
        } else if (!region.containsSphere(x, r)) {
          x = site;  // the unshifted site holds a sphere of the largest radius
        }
        if (haveExisting && existing.overlaps(x, r)) continue;
        if (avoid.reject && avoid.reject(x, r)) continue;
        out.position.push_back(x);
        out.radius.push_back(r);
      }
    }
  }
  if (usable == 0) {
    return invalidArgument("lattice: the region (bounds " + num(b.min.x) + ".." + num(b.max.x) + ", " + num(b.min.y) + ".." + num(b.max.y) + ", " +
                           num(b.min.z) + ".." + num(b.max.z) + ") is too small to hold one sphere of radius " + num(rmax) + " on the lattice");
  }
  if (options.count && out.size() < *options.count) {
    return exhausted("lattice: count " + std::to_string(*options.count) + " is more than the " + std::to_string(out.size()) +
                     " lattice particles that fit (" + std::to_string(usable) + " sites inside the region of " + std::to_string(nx) + " x " +
                     std::to_string(ny) + " x " + std::to_string(nz) + " in its bounds" +
                     (usable > out.size() ? ", " + std::to_string(usable - out.size()) + " of them blocked by existing spheres or the reject rule" : "") +
                     ")");
  }
  return out;
}

// ---- random -------------------------------------------------------------------------------------------------------

ErrorList checkRandom(const SizeDistribution& size, const RandomOptions& options, const Avoid& avoid) {
  ErrorList e = size.validate("random.size");
  validateAvoid(avoid, e);
  validateFraction(options.count, options.solidFraction, "random", true, e);
  if (options.maxAttemptsPerParticle < 1) e.add("random.max_attempts", "0 must be >= 1");
  return e;
}

Result<Particles> generateRandom(const Region& region, const SizeDistribution& size, const RandomOptions& options, std::uint64_t seed,
                                 const Avoid& avoid) {
  if (ErrorList e = checkRandom(size, options, avoid); !e.empty()) return e.toStatus("random");
  const double regionVolume = std::fabs(region.volume());

  Random rng(seed);
  const std::vector<double> radii = drawRadii(size, options.count, options.solidFraction.value_or(0) * regionVolume, rng);
  double wantedVolume = 0;
  for (double r : radii) wantedVolume += sphereVolume(r);

  const Bounds b = region.bounds();
  const double rmax = radii.empty() ? size.maxRadius() : radii.front();
  const double rmin = radii.empty() ? size.minRadius() : radii.back();
  const Bounds centres{b.min + Vec3d{rmin, rmin, rmin}, b.max - Vec3d{rmin, rmin, rmin}};
  const Vec3d room = centres.size();
  if (!radii.empty() && !(room.x >= 0 && room.y >= 0 && room.z >= 0)) {
    return exhausted("random: the region's bounds cannot hold one sphere of radius " + num(rmin));
  }
  SphereGrid grid = existingGrid(b, rmax, avoid, radii.size() + avoid.position.size());
  FreeSpace space(centres, rmin, radii.size());
  for (std::size_t i = 0; i < avoid.position.size(); ++i) space.cover(avoid.position[i], avoid.radius[i], false);
  Particles out;
  out.position.reserve(radii.size());
  out.radius.reserve(radii.size());
  const auto outcome = sequentialAddition(
      radii, options.maxAttemptsPerParticle, centres, false, grid, space, rng,
      [&](const Vec3d& p, double r) { return region.containsSphere(p, r) && !(avoid.reject && avoid.reject(p, r)); },
      [&](const Vec3d& p, double r) {
        out.position.push_back(p);
        out.radius.push_back(r);
      });
  if (!outcome.complete) {
    return exhausted("random: the region cannot hold the request: " + failureReport(outcome, radii, options.maxAttemptsPerParticle) + "; " +
                     fractionReport(outcome.placedVolume, wantedVolume, regionVolume));
  }
  return out;
}

// ---- tiled --------------------------------------------------------------------------------------------------------

ErrorList checkTiled(const SizeDistribution& size, const TiledOptions& options, const Avoid& avoid) {
  ErrorList e = size.validate("tiled.size");
  validateAvoid(avoid, e);
  validateFraction(options.count, options.solidFraction, "tiled", false, e);
  if (options.maxAttemptsPerParticle < 1) e.add("tiled.max_attempts", "0 must be >= 1");
  const double rmax = size.maxRadius();
  const double edge = options.tileEdge > 0 ? options.tileEdge : 20 * rmax;
  if (!std::isfinite(options.tileEdge) || options.tileEdge < 0) {
    e.add("tiled.tile_edge", num(options.tileEdge) + " must be >= 0 (0: 10 x the largest diameter)");
  } else if (e.empty() && !(edge >= 4 * rmax)) {
    e.add("tiled.tile_edge", num(edge) + " must be >= 2 x the largest diameter " + num(2 * rmax));
  }
  return e;
}

Result<Particles> generateTiled(const Region& region, const SizeDistribution& size, const TiledOptions& options, std::uint64_t seed,
                                const Avoid& avoid) {
  if (ErrorList e = checkTiled(size, options, avoid); !e.empty()) return e.toStatus("tiled");
  const double rmax = size.maxRadius();
  const double edge = options.tileEdge > 0 ? options.tileEdge : 20 * rmax;

  // 1. The tile: random sequential addition in the periodic cube [0, edge)^3.
  Random rng(seed);
  const double fraction = options.solidFraction.value_or(TiledOptions::kDefaultTileSolidFraction);
  const double tileVolume = edge * edge * edge;
  const std::vector<double> radii = drawRadii(size, std::nullopt, fraction * tileVolume, rng);
  double wantedVolume = 0;
  for (double r : radii) wantedVolume += sphereVolume(r);
  SphereGrid tileGrid = SphereGrid::periodic(edge, 2 * (radii.empty() ? rmax : radii.front()));
  FreeSpace space(Bounds{{0, 0, 0}, {edge, edge, edge}}, radii.empty() ? rmax : radii.back(), radii.size());
  std::vector<Vec3d> tileP;
  std::vector<double> tileR;
  const auto outcome = sequentialAddition(
      radii, options.maxAttemptsPerParticle, Bounds{{0, 0, 0}, {edge, edge, edge}}, true, tileGrid, space, rng, [](const Vec3d&, double) { return true; },
      [&](const Vec3d& p, double r) {
        // [0, edge) exactly, so that copies sit at exact tile offsets.
        tileP.push_back({p.x < edge ? p.x : 0.0, p.y < edge ? p.y : 0.0, p.z < edge ? p.z : 0.0});
        tileR.push_back(r);
      });
  if (!outcome.complete) {
    return exhausted("tiled: the periodic tile (edge " + num(edge) + ") cannot hold the request: " + failureReport(outcome, radii, options.maxAttemptsPerParticle) +
                     "; " + fractionReport(outcome.placedVolume, wantedVolume, tileVolume));
  }

  // 2. Copies at bounds.min + (i, j, k) edge, kept where inside the region and clear of Avoid.
  const Bounds b = region.bounds();
  const Vec3d s = b.size();
  const long tx = std::max(1L, static_cast<long>(std::ceil(s.x / edge))), ty = std::max(1L, static_cast<long>(std::ceil(s.y / edge))),
             tz = std::max(1L, static_cast<long>(std::ceil(s.z / edge)));
  SphereGrid existing = existingGrid(b, rmax, avoid, 0);
  const bool haveExisting = !avoid.position.empty();
  struct Kept {
    Vec3d p;
    double r;
    std::size_t tile, index;
  };
  std::vector<Kept> kept;
  for (long k = 0; k < tz; ++k) {
    for (long j = 0; j < ty; ++j) {
      for (long i = 0; i < tx; ++i) {
        const Vec3d origin{b.min.x + static_cast<double>(i) * edge, b.min.y + static_cast<double>(j) * edge, b.min.z + static_cast<double>(k) * edge};
        const std::size_t tile = static_cast<std::size_t>((k * ty + j) * tx + i);
        for (std::size_t n = 0; n < tileP.size(); ++n) {
          const Vec3d p = origin + tileP[n];
          const double r = tileR[n];
          if (!region.containsSphere(p, r)) continue;
          if (haveExisting && existing.overlaps(p, r)) continue;
          if (avoid.reject && avoid.reject(p, r)) continue;
          kept.push_back({p, r, tile, n});
        }
      }
    }
  }
  // Fill order: lowest z first (then y, then x; ties by tile and index, so the order is total).
  std::sort(kept.begin(), kept.end(), [](const Kept& a, const Kept& c) {
    if (a.p.z != c.p.z) return a.p.z < c.p.z;
    if (a.p.y != c.p.y) return a.p.y < c.p.y;
    if (a.p.x != c.p.x) return a.p.x < c.p.x;
    return a.tile != c.tile ? a.tile < c.tile : a.index < c.index;
  });
  if (options.count && kept.size() < *options.count) {
    return exhausted("tiled: count " + std::to_string(*options.count) + " is more than the " + std::to_string(kept.size()) +
                     " particles the region holds with a tile at solid fraction " + num(fraction) + " (" + std::to_string(tileP.size()) +
                     " particles per tile of edge " + num(edge) + "); raise solid_fraction or enlarge the region");
  }
  const std::size_t n = options.count ? *options.count : kept.size();
  Particles out;
  out.position.reserve(n);
  out.radius.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    out.position.push_back(kept[i].p);
    out.radius.push_back(kept[i].r);
  }
  return out;
}

// ---- list ---------------------------------------------------------------------------------------------------------

Result<Particles> generateList(const Particles& particles, const Avoid& avoid, const Region* region) {
  ErrorList e;
  validateAvoid(avoid, e);
  if (particles.position.size() != particles.radius.size()) {
    e.add("list", std::to_string(particles.position.size()) + " positions but " + std::to_string(particles.radius.size()) + " radii");
    return e.toStatus("list");
  }
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const std::string at = "list[" + std::to_string(i) + "]";
    const Vec3d& p = particles.position[i];
    const double r = particles.radius[i];
    if (!isFinite(p)) e.add(at + ".position", "must be finite");
    if (!std::isfinite(r) || !(r > 0)) e.add(at + ".radius", num(r) + " must be > 0");
    if (!isFinite(p) || !(r > 0) || !std::isfinite(r)) continue;
    if (region && !region->containsSphere(p, r)) e.add(at, "the sphere at [" + num(p.x) + ", " + num(p.y) + ", " + num(p.z) + "] with radius " + num(r) + " is not inside the region");
    if (avoid.reject && avoid.reject(p, r)) e.add(at, "rejected (it overlaps a wall or another excluded place)");
  }
  if (!e.empty()) return e.toStatus("list");
  for (const Overlap& o : findOverlaps(particles.position, particles.radius, 1e-9, 20, avoid.position, avoid.radius)) {
    const bool withExisting = o.j >= particles.size();
    e.add("list[" + std::to_string(o.i) + "]", "overlaps " + (withExisting ? "existing sphere " + std::to_string(o.j - particles.size()) : "list[" + std::to_string(o.j) + "]") +
                                                   " by " + num(o.depth) + " m");
  }
  if (!e.empty()) return e.toStatus("list");
  return particles;
}

// ---- overlaps -----------------------------------------------------------------------------------------------------

std::vector<Overlap> findOverlaps(std::span<const Vec3d> position, std::span<const double> radius, double tolerance, std::size_t maxReport,
                                  std::span<const Vec3d> existingPosition, std::span<const double> existingRadius) {
  std::vector<Overlap> out;
  const std::size_t n = std::min(position.size(), radius.size());
  if (n == 0 || maxReport == 0) return out;
  Bounds b{position[0], position[0]};
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d& p = position[i];
    b.min = {std::min(b.min.x, p.x), std::min(b.min.y, p.y), std::min(b.min.z, p.z)};
    b.max = {std::max(b.max.x, p.x), std::max(b.max.y, p.y), std::max(b.max.z, p.z)};
  }
  const double rmax = maxOf(radius.first(n));
  const double rOld = maxOf(existingRadius);
  const double reach = rmax + std::max(rmax, rOld);
  SphereGrid grid(b, std::max(reach, 1e-300), n);
  for (std::size_t i = 0; i < n; ++i) grid.insert(position[i], radius[i], i);
  const Vec3d lo = b.min - Vec3d{reach, reach, reach}, hi = b.max + Vec3d{reach, reach, reach};
  for (std::size_t j = 0; j < std::min(existingPosition.size(), existingRadius.size()); ++j) {
    const Vec3d& p = existingPosition[j];
    if (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z) grid.insert(p, existingRadius[j], n + j);
  }
  for (std::size_t i = 0; i < n && out.size() < maxReport; ++i) {
    grid.anyNear(position[i], [&](const SphereGrid::Sphere& s, std::size_t j) {
      if (j <= i) return false;  // each pair once; existing spheres have j >= n > i
      const double depth = radius[i] + s.r - norm(position[i] - s.c);
      if (depth > tolerance * std::min(radius[i], s.r)) out.push_back({i, j, depth});
      return out.size() >= maxReport;
    });
  }
  return out;
}

}  // namespace pflow::frontend
