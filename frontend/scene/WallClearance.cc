#include "frontend/scene/WallClearance.h"

#include <algorithm>
#include <cmath>

#include "compute/geometry/TriangleGeometry.h"

namespace pflow::frontend::detail {

namespace {
constexpr double kMaxCells = double(1 << 21);  // 8 MiB of cell starts at most
}

WallClearance::WallClearance(const std::vector<compute::PlaneConfig>& planes, const std::vector<compute::MeshConfig>& meshes)
    : m_planes(planes) {
  for (auto& p : m_planes) {
    const double len = norm(p.normal);
    if (len > 0) p.normal = (1.0 / len) * p.normal;
  }
  Vec3d lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (const auto& m : meshes) {
    for (const auto& t : m.triangles) {
      if (t[0] >= m.vertices.size() || t[1] >= m.vertices.size() || t[2] >= m.vertices.size()) continue;  // validate() reports it
      const Tri tri{m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]};
      if (!isFinite(tri.a) || !isFinite(tri.b) || !isFinite(tri.c)) continue;
      m_tris.push_back(tri);
      for (const Vec3d& v : {tri.a, tri.b, tri.c}) {
        lo = {std::min(lo.x, v.x), std::min(lo.y, v.y), std::min(lo.z, v.z)};
        hi = {std::max(hi.x, v.x), std::max(hi.y, v.y), std::max(hi.z, v.z)};
      }
    }
  }
  if (m_tris.empty()) return;
  const Vec3d ext = hi - lo;
  // Cubic cells, about one per triangle over the triangles' box (flat walls: thin boxes count their thickness as
  // one cell), so the grid's memory follows the walls, not the particle size.
  const double largest = std::max({ext.x, ext.y, ext.z});
  const double targetCells = std::min(kMaxCells, std::max(1.0, double(m_tris.size())));
  const double volume = std::max(ext.x, largest * 1e-3) * std::max(ext.y, largest * 1e-3) * std::max(ext.z, largest * 1e-3);
  m_cell = std::max({std::cbrt(volume / targetCells), largest / 256, 1e-12});
  m_lo = lo;
  const double e[3] = {ext.x, ext.y, ext.z};
  for (int k = 0; k < 3; ++k) m_n[k] = std::max(1, int(std::floor(e[k] / m_cell)) + 1);
  auto cellRange = [&](const Tri& t, int lo3[3], int hi3[3]) {
    const double mn[3] = {std::min({t.a.x, t.b.x, t.c.x}), std::min({t.a.y, t.b.y, t.c.y}), std::min({t.a.z, t.b.z, t.c.z})};
    const double mx[3] = {std::max({t.a.x, t.b.x, t.c.x}), std::max({t.a.y, t.b.y, t.c.y}), std::max({t.a.z, t.b.z, t.c.z})};
    const double o[3] = {m_lo.x, m_lo.y, m_lo.z};
    for (int k = 0; k < 3; ++k) {
      lo3[k] = std::clamp(int(std::floor((mn[k] - o[k]) / m_cell)), 0, m_n[k] - 1);
      hi3[k] = std::clamp(int(std::floor((mx[k] - o[k]) / m_cell)), 0, m_n[k] - 1);
    }
  };
  const std::size_t cells = std::size_t(m_n[0]) * m_n[1] * m_n[2];
  std::vector<std::uint32_t> count(cells + 1, 0);
  auto visit = [&](auto&& f) {
    for (std::uint32_t t = 0; t < m_tris.size(); ++t) {
      int a[3], b[3];
      cellRange(m_tris[t], a, b);
      for (int z = a[2]; z <= b[2]; ++z)
        for (int y = a[1]; y <= b[1]; ++y)
          for (int x = a[0]; x <= b[0]; ++x) f(t, (std::size_t(z) * m_n[1] + y) * m_n[0] + x);
    }
  };
  visit([&](std::uint32_t, std::size_t c) { ++count[c + 1]; });
  for (std::size_t c = 0; c < cells; ++c) count[c + 1] += count[c];
  m_cellStart = count;
  m_cellTris.resize(count[cells]);
  visit([&](std::uint32_t t, std::size_t c) { m_cellTris[count[c]++] = t; });
}

bool WallClearance::touches(const Vec3d& centre, double radius) const {
  for (const auto& p : m_planes)
    if (dot(centre - p.point, p.normal) < radius) return true;
  if (m_tris.empty()) return false;
  const double c[3] = {centre.x, centre.y, centre.z}, o[3] = {m_lo.x, m_lo.y, m_lo.z};
  int a[3], b[3];
  for (int k = 0; k < 3; ++k) {
    a[k] = int(std::floor((c[k] - radius - o[k]) / m_cell));
    b[k] = int(std::floor((c[k] + radius - o[k]) / m_cell));
    if (b[k] < 0 || a[k] >= m_n[k]) return false;  // beyond every triangle's cell
    a[k] = std::max(a[k], 0);
    b[k] = std::min(b[k], m_n[k] - 1);
  }
  const double r2 = radius * radius;
  for (int z = a[2]; z <= b[2]; ++z)
    for (int y = a[1]; y <= b[1]; ++y)
      for (int x = a[0]; x <= b[0]; ++x) {
        const std::size_t cell = (std::size_t(z) * m_n[1] + y) * m_n[0] + x;
        for (std::uint32_t k = m_cellStart[cell]; k < m_cellStart[cell + 1]; ++k) {
          const Tri& t = m_tris[m_cellTris[k]];
          const auto cp = compute::geometry::closestPointOnTriangle(centre, t.a, t.b, t.c);
          if (norm2(cp.point - centre) < r2) return true;
        }
      }
  return false;
}

}  // namespace pflow::frontend::detail
