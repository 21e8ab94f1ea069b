#include "frontend/generators/Region.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <sstream>
#include <vector>

#include "compute/geometry/TriangleGeometry.h"

namespace pflow::frontend {
namespace {

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

std::string vec(const Vec3d& v) {
  std::ostringstream os;
  os << '[' << v.x << ", " << v.y << ", " << v.z << ']';
  return os.str();
}

double component(const Vec3d& v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }

// A compressed list of items per cell: items of cell c are ids[offset[c] .. offset[c + 1]).
struct CellLists {
  std::vector<std::uint32_t> offset, ids;

  // cellsOf(item, visit) calls visit(cell) for every cell of an item; two passes (count, fill).
  template <class CellsOf>
  void build(std::size_t cells, std::size_t items, CellsOf cellsOf) {
    offset.assign(cells + 1, 0);
    for (std::size_t t = 0; t < items; ++t) cellsOf(t, [&](std::size_t c) { ++offset[c + 1]; });
    for (std::size_t c = 0; c < cells; ++c) offset[c + 1] += offset[c];
    ids.resize(offset[cells]);
    std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
    for (std::size_t t = 0; t < items; ++t) cellsOf(t, [&](std::size_t c) { ids[fill[c]++] = static_cast<std::uint32_t>(t); });
  }
};

}  // namespace

// ---- mesh index ---------------------------------------------------------------------------------------------------
//
// Inside test: the winding number of the mesh around p along the ray from p towards +z. A triangle whose x-y
// projection contains p's (x, y) and whose plane lies above p adds +1 if it faces up (normal z > 0) and -1 if it
// faces down. Points on a projected edge are counted by exactly one of the two triangles sharing it: each edge
// function is evaluated once per undirected edge (from its lower to its higher vertex index, negated for the other
// direction) and ties go by the edge's direction, which the two triangles see reversed. Only triangles in p's
// column of a uniform x-y grid are visited.
//
// Distance test: triangles binned by bounding box into a uniform 3-D grid; a sphere visits the cells its own
// bounding box overlaps.
struct Region::MeshIndex {
  struct Projected {
    std::array<std::uint32_t, 3> v;  // counter-clockwise seen from +z
    int sign;                        // +1: faces up, -1: faces down
    Vec3d normal;                    // (b - a) x (c - a) of the reordered triangle (normal.z > 0)
  };
  std::vector<Vec3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<Projected> projected;
  double signedVolume = 0;
  Bounds box;

  // x-y columns
  std::size_t cx = 1, cy = 1;
  double colW = 1, colH = 1;
  CellLists columns;
  // 3-D cells
  std::array<std::size_t, 3> n{1, 1, 1};
  double cell = 1;
  CellLists cells;

  // Edge function of q against the directed edge u -> v: > 0 when q is left of it (x-y plane).
  double edgeFunction(std::uint32_t u, std::uint32_t v, double qx, double qy) const {
    const std::uint32_t lo = std::min(u, v), hi = std::max(u, v);
    const Vec3d& a = vertices[lo];
    const Vec3d& b = vertices[hi];
    const double e = (b.x - a.x) * (qy - a.y) - (b.y - a.y) * (qx - a.x);
    return u == lo ? e : -e;
  }
  // Tie rule for q on the edge u -> v: exactly one of the two directions owns it.
  bool ownsEdge(std::uint32_t u, std::uint32_t v) const {
    const double dx = vertices[v].x - vertices[u].x, dy = vertices[v].y - vertices[u].y;
    return dy < 0 || (dy == 0 && dx > 0);
  }

  bool contains(const Vec3d& p) const {
    if (p.x < box.min.x || p.x > box.max.x || p.y < box.min.y || p.y > box.max.y || p.z < box.min.z || p.z > box.max.z) return false;
    const auto ix = std::min(cx - 1, static_cast<std::size_t>(std::max(0.0, (p.x - box.min.x) / colW)));
    const auto iy = std::min(cy - 1, static_cast<std::size_t>(std::max(0.0, (p.y - box.min.y) / colH)));
    const std::size_t c = iy * cx + ix;
    int winding = 0;
    for (std::uint32_t k = columns.offset[c]; k < columns.offset[c + 1]; ++k) {
      const Projected& t = projected[columns.ids[k]];
      bool in = true;
      for (int e = 0; e < 3 && in; ++e) {
        const std::uint32_t u = t.v[e], v = t.v[(e + 1) % 3];
        const double f = edgeFunction(u, v, p.x, p.y);
        in = f > 0 || (f == 0 && ownsEdge(u, v));
      }
      if (!in) continue;
      const Vec3d& a = vertices[t.v[0]];
      const double zPlane = a.z - (t.normal.x * (p.x - a.x) + t.normal.y * (p.y - a.y)) / t.normal.z;
      if (zPlane > p.z) winding += t.sign;
    }
    return winding != 0;
  }

  // True when some triangle is closer to p than r.
  bool closerThan(const Vec3d& p, double r) const {
    const Vec3d lo = p - Vec3d{r, r, r}, hi = p + Vec3d{r, r, r};
    std::array<std::size_t, 3> i0{}, i1{};
    for (int a = 0; a < 3; ++a) {
      const double o = component(box.min, a);
      const double f0 = std::floor((component(lo, a) - o) / cell), f1 = std::floor((component(hi, a) - o) / cell);
      const double top = static_cast<double>(n[a] - 1);
      i0[a] = static_cast<std::size_t>(std::clamp(f0, 0.0, top));
      i1[a] = static_cast<std::size_t>(std::clamp(f1, 0.0, top));
    }
    const double r2 = r * r;
    for (std::size_t z = i0[2]; z <= i1[2]; ++z) {
      for (std::size_t y = i0[1]; y <= i1[1]; ++y) {
        for (std::size_t x = i0[0]; x <= i1[0]; ++x) {
          const std::size_t c = (z * n[1] + y) * n[0] + x;
          for (std::uint32_t k = cells.offset[c]; k < cells.offset[c + 1]; ++k) {
            const auto& t = triangles[cells.ids[k]];
            const Vec3d q = compute::geometry::closestPointOnTriangle(p, vertices[t[0]], vertices[t[1]], vertices[t[2]]).point;
            if (norm2(q - p) < r2) return true;
          }
        }
      }
    }
    return false;
  }
};

// ---- factories ----------------------------------------------------------------------------------------------------

Result<Region> Region::box(const Vec3d& min, const Vec3d& max) {
  if (!isFinite(min) || !isFinite(max) || !(max.x > min.x && max.y > min.y && max.z > min.z)) {
    return invalidArgument("box: max " + vec(max) + " must be > min " + vec(min) + " on every axis (finite)");
  }
  Region r;
  r.m_kind = Kind::kBox;
  r.m_bounds = {min, max};
  return r;
}

Result<Region> Region::cylinder(const Vec3d& baseCentre, const Vec3d& axis, double radius, double height) {
  ErrorList e;
  if (!isFinite(baseCentre)) e.add("cylinder.base", vec(baseCentre) + " must be finite");
  const double len = norm(axis);
  if (!isFinite(axis) || !(len > 0)) e.add("cylinder.axis", vec(axis) + " must be a finite non-zero vector");
  if (!std::isfinite(radius) || !(radius > 0)) e.add("cylinder.radius", num(radius) + " must be > 0");
  if (!std::isfinite(height) || !(height > 0)) e.add("cylinder.height", num(height) + " must be > 0");
  if (!e.empty()) return e.toStatus("cylinder region");
  Region r;
  r.m_kind = Kind::kCylinder;
  r.m_base = baseCentre;
  r.m_axis = (1.0 / len) * axis;
  r.m_radius = radius;
  r.m_height = height;
  const Vec3d top = baseCentre + height * r.m_axis;
  // A disc of radius R normal to unit a reaches R sqrt(1 - a_i^2) along axis i.
  const Vec3d reach{radius * std::sqrt(std::max(0.0, 1 - r.m_axis.x * r.m_axis.x)), radius * std::sqrt(std::max(0.0, 1 - r.m_axis.y * r.m_axis.y)),
                    radius * std::sqrt(std::max(0.0, 1 - r.m_axis.z * r.m_axis.z))};
  r.m_bounds.min = Vec3d{std::min(baseCentre.x, top.x), std::min(baseCentre.y, top.y), std::min(baseCentre.z, top.z)} - reach;
  r.m_bounds.max = Vec3d{std::max(baseCentre.x, top.x), std::max(baseCentre.y, top.y), std::max(baseCentre.z, top.z)} + reach;
  return r;
}

Result<Region> Region::mesh(const TriMesh& mesh) {
  ErrorList e;
  const std::size_t nv = mesh.vertices.size(), nt = mesh.triangles.size();
  if (nt < 4) e.add("mesh.triangles", "has " + std::to_string(nt) + " triangles; a closed mesh needs at least 4");
  for (std::size_t i = 0; i < nv; ++i) {
    if (!isFinite(mesh.vertices[i])) e.add("mesh.vertices[" + std::to_string(i) + "]", vec(mesh.vertices[i]) + " must be finite");
  }
  for (std::size_t t = 0; t < nt; ++t) {
    for (std::uint32_t v : mesh.triangles[t]) {
      if (v >= nv) e.add("mesh.triangles[" + std::to_string(t) + "]", "vertex index " + std::to_string(v) + " is not below the vertex count " + std::to_string(nv));
    }
  }
  if (!e.empty()) return e.toStatus("mesh region");

  // Closed and consistently oriented: every directed edge u -> v appears once, and so does v -> u.
  std::vector<std::uint64_t> directed;
  directed.reserve(3 * nt);
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) directed.push_back(std::uint64_t{t[k]} << 32 | t[(k + 1) % 3]);
  }
  std::sort(directed.begin(), directed.end());
  std::size_t reported = 0;
  auto edgeName = [](std::uint64_t key) {
    std::ostringstream os;
    os << '(' << (key >> 32) << ", " << (key & 0xffffffffu) << ')';
    return os.str();
  };
  for (std::size_t i = 0; i < directed.size() && reported < 10; ++i) {
    const std::uint64_t key = directed[i];
    if (i + 1 < directed.size() && directed[i + 1] == key) {
      e.add("mesh", "edge " + edgeName(key) + " is traversed in the same direction by two triangles: the orientation is inconsistent (or the mesh is not manifold)");
      ++reported;
      continue;
    }
    const std::uint64_t reverse = (key & 0xffffffffu) << 32 | (key >> 32);
    if (!std::binary_search(directed.begin(), directed.end(), reverse)) {
      e.add("mesh", "edge " + edgeName(key) + " belongs to one triangle only: the mesh is not closed");
      ++reported;
    }
  }
  if (!e.empty()) return e.toStatus("mesh region");

  auto index = std::make_shared<MeshIndex>();
  MeshIndex& m = *index;
  m.vertices = mesh.vertices;
  m.triangles = mesh.triangles;
  m.box = {m.vertices[m.triangles[0][0]], m.vertices[m.triangles[0][0]]};
  for (const auto& t : m.triangles) {
    for (std::uint32_t v : t) {
      const Vec3d& p = m.vertices[v];
      m.box.min = {std::min(m.box.min.x, p.x), std::min(m.box.min.y, p.y), std::min(m.box.min.z, p.z)};
      m.box.max = {std::max(m.box.max.x, p.x), std::max(m.box.max.y, p.y), std::max(m.box.max.z, p.z)};
    }
  }
  double volume = 0;
  for (const auto& t : m.triangles) volume += dot(m.vertices[t[0]], cross(m.vertices[t[1]], m.vertices[t[2]]));
  m.signedVolume = volume / 6.0;
  const Vec3d size = m.box.size();
  if (!(size.x > 0 && size.y > 0 && size.z > 0) || !(std::fabs(m.signedVolume) > 0)) {
    return invalidArgument("mesh region: the mesh encloses no volume (bounds " + vec(m.box.min) + " - " + vec(m.box.max) + ")");
  }

  // Triangles that project onto the x-y plane with non-zero area, counter-clockwise.
  for (const auto& t : m.triangles) {
    const Vec3d &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    const Vec3d nrm = cross(b - a, c - a);
    if (nrm.z == 0) continue;  // vertical: the ray along z never crosses it
    MeshIndex::Projected p;
    p.sign = nrm.z > 0 ? 1 : -1;
    p.v = nrm.z > 0 ? t : std::array<std::uint32_t, 3>{t[0], t[2], t[1]};
    p.normal = nrm.z > 0 ? nrm : -nrm;
    m.projected.push_back(p);
  }

  // Column grid: about one column per triangle, square columns.
  const double target = std::max<double>(1, static_cast<double>(nt));
  const double side = std::sqrt(size.x * size.y / target);
  m.cx = static_cast<std::size_t>(std::clamp(std::ceil(size.x / side), 1.0, 4096.0));
  m.cy = static_cast<std::size_t>(std::clamp(std::ceil(size.y / side), 1.0, 4096.0));
  m.colW = size.x / static_cast<double>(m.cx);
  m.colH = size.y / static_cast<double>(m.cy);
  auto colRange = [](double lo, double hi, double origin, double w, std::size_t count) {
    const double top = static_cast<double>(count - 1);
    return std::pair<std::size_t, std::size_t>{static_cast<std::size_t>(std::clamp(std::floor((lo - origin) / w), 0.0, top)),
                                               static_cast<std::size_t>(std::clamp(std::floor((hi - origin) / w), 0.0, top))};
  };
  // A triangle goes into the columns its projection overlaps, row by row: in the row's slab ylo <= y <= yhi the
  // clipped triangle spans the x of its vertices inside the slab and of its edges' crossings of the slab's two
  // lines. (Its bounding box alone would put a long triangle across the grid's diagonal into most columns, and
  // every inside test would then visit most triangles.)
  m.columns.build(m.cx * m.cy, m.projected.size(), [&](std::size_t i, auto visit) {
    const auto& v = m.projected[i].v;
    const Vec3d* p[3] = {&m.vertices[v[0]], &m.vertices[v[1]], &m.vertices[v[2]]};
    const auto [y0, y1] = colRange(std::min({p[0]->y, p[1]->y, p[2]->y}), std::max({p[0]->y, p[1]->y, p[2]->y}), m.box.min.y, m.colH, m.cy);
    for (std::size_t y = y0; y <= y1; ++y) {
      // The slab, widened by a rounding margin so that a point on a row boundary finds the triangle either way.
      const double margin = 1e-9 * m.colH;
      const double ylo = y == y0 ? -std::numeric_limits<double>::infinity() : m.box.min.y + static_cast<double>(y) * m.colH - margin;
      const double yhi = y == y1 ? std::numeric_limits<double>::infinity() : m.box.min.y + static_cast<double>(y + 1) * m.colH + margin;
      double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo;
      auto take = [&](double x) {
        xlo = std::min(xlo, x);
        xhi = std::max(xhi, x);
      };
      for (int k = 0; k < 3; ++k) {
        const Vec3d &a = *p[k], &b = *p[(k + 1) % 3];
        if (a.y >= ylo && a.y <= yhi) take(a.x);
        for (double line : {ylo, yhi}) {
          if (!std::isfinite(line) || (a.y - line) * (b.y - line) > 0 || a.y == b.y) continue;
          take(a.x + (b.x - a.x) * (line - a.y) / (b.y - a.y));
        }
      }
      if (!(xlo <= xhi)) continue;
      const auto [x0, x1] = colRange(xlo - 1e-9 * m.colW, xhi + 1e-9 * m.colW, m.box.min.x, m.colW, m.cx);
      for (std::size_t x = x0; x <= x1; ++x) visit(y * m.cx + x);
    }
  });

  // Cell grid: about one cell per triangle, cubic cells, at most 256 per axis.
  m.cell = std::cbrt(size.x * size.y * size.z / target);
  for (int a = 0; a < 3; ++a) {
    m.cell = std::max(m.cell, component(size, a) / 256.0);
  }
  for (int a = 0; a < 3; ++a) m.n[a] = static_cast<std::size_t>(std::clamp(std::ceil(component(size, a) / m.cell), 1.0, 256.0));
  m.cells.build(m.n[0] * m.n[1] * m.n[2], nt, [&](std::size_t i, auto visit) {
    const auto& t = m.triangles[i];
    std::array<std::pair<std::size_t, std::size_t>, 3> range;
    for (int a = 0; a < 3; ++a) {
      const double p0 = component(m.vertices[t[0]], a), p1 = component(m.vertices[t[1]], a), p2 = component(m.vertices[t[2]], a);
      range[a] = colRange(std::min({p0, p1, p2}), std::max({p0, p1, p2}), component(m.box.min, a), m.cell, m.n[a]);
    }
    for (std::size_t z = range[2].first; z <= range[2].second; ++z)
      for (std::size_t y = range[1].first; y <= range[1].second; ++y)
        for (std::size_t x = range[0].first; x <= range[0].second; ++x) visit((z * m.n[1] + y) * m.n[0] + x);
  });

  Region r;
  r.m_kind = Kind::kMesh;
  r.m_bounds = m.box;
  r.m_mesh = std::move(index);
  return r;
}

// ---- queries ------------------------------------------------------------------------------------------------------

bool Region::containsPoint(const Vec3d& p) const { return containsSphere(p, 0.0); }

bool Region::containsSphere(const Vec3d& c, double r) const {
  switch (m_kind) {
    case Kind::kBox:
      return c.x - r >= m_bounds.min.x && c.x + r <= m_bounds.max.x && c.y - r >= m_bounds.min.y && c.y + r <= m_bounds.max.y &&
             c.z - r >= m_bounds.min.z && c.z + r <= m_bounds.max.z;
    case Kind::kCylinder: {
      const Vec3d d = c - m_base;
      const double t = dot(d, m_axis);
      if (!(t - r >= 0 && t + r <= m_height)) return false;
      const double rho2 = norm2(d - t * m_axis);
      const double room = m_radius - r;
      return room >= 0 && rho2 <= room * room;
    }
    case Kind::kMesh: {
      // A sphere inside a closed surface lies inside the surface's bounding box.
      if (c.x - r < m_bounds.min.x || c.x + r > m_bounds.max.x || c.y - r < m_bounds.min.y || c.y + r > m_bounds.max.y ||
          c.z - r < m_bounds.min.z || c.z + r > m_bounds.max.z) {
        return false;
      }
      if (!m_mesh->contains(c)) return false;
      return r <= 0 || !m_mesh->closerThan(c, r);
    }
  }
  return false;
}

double Region::volume() const {
  switch (m_kind) {
    case Kind::kBox: {
      const Vec3d s = m_bounds.size();
      return s.x * s.y * s.z;
    }
    case Kind::kCylinder:
      return std::numbers::pi * m_radius * m_radius * m_height;
    case Kind::kMesh:
      return m_mesh->signedVolume;
  }
  return 0;
}

Vec3d Region::samplePoint(Random& rng) const {
  const Vec3d s = m_bounds.size();
  const double x = rng.uniform(), y = rng.uniform(), z = rng.uniform();
  return m_bounds.min + Vec3d{x * s.x, y * s.y, z * s.z};
}

}  // namespace pflow::frontend
