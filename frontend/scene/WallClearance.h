// "Does a sphere here touch a wall?" for the particle generators: planes and the triangles of every mesh (at
// their initial position), the triangles binned in a uniform grid so that a query costs O(1).
#pragma once
#include <cstdint>
#include <vector>

#include "compute/core/VectorMath.h"
#include "compute/sim/RunConfig.h"

namespace pflow::frontend::detail {

class WallClearance {
 public:
  // The grid has about as many cells as triangles (at most 2^21 cells), whatever the particle sizes, so one
  // instance serves every particle set of a scene.
  WallClearance(const std::vector<compute::PlaneConfig>& planes, const std::vector<compute::MeshConfig>& meshes);

  // True when a sphere of `radius` at `centre` overlaps a wall: it is closer than `radius` to a triangle, or its
  // centre is less than `radius` in front of a plane (or behind it).
  bool touches(const Vec3d& centre, double radius) const;
  bool empty() const { return m_planes.empty() && m_tris.empty(); }

 private:
  struct Tri {
    Vec3d a, b, c;
  };
  std::vector<compute::PlaneConfig> m_planes;
  std::vector<Tri> m_tris;
  Vec3d m_lo{0, 0, 0};
  double m_cell = 1;
  int m_n[3] = {0, 0, 0};
  std::vector<std::uint32_t> m_cellStart;  // CSR over cells
  std::vector<std::uint32_t> m_cellTris;
};

}  // namespace pflow::frontend::detail
