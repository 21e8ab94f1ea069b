// Regions the generators fill: a box, a cylinder, or the inside of a closed triangle mesh. SI units.
// A sphere is inside a region when all of it is: containsSphere(centre, r).
#pragma once
#include <memory>
#include <string>

#include "common/Status.h"
#include "compute/core/VectorMath.h"
#include "frontend/generators/Random.h"
#include "frontend/geometry/TriMesh.h"

namespace pflow::frontend {

struct Bounds {
  Vec3d min{0, 0, 0}, max{0, 0, 0};  // [m]
  Vec3d size() const { return max - min; }
};

class Region {
 public:
  enum class Kind { kBox, kCylinder, kMesh };

  // Axis-aligned box; max > min on every axis.
  static Result<Region> box(const Vec3d& min, const Vec3d& max);
  // Solid cylinder from baseCentre along axis (any non-zero length; normalised here) for `height`.
  static Result<Region> cylinder(const Vec3d& baseCentre, const Vec3d& axis, double radius, double height);
  // The inside of a closed, consistently oriented triangle mesh (every edge shared by exactly two triangles that
  // traverse it in opposite directions). Either orientation works: inside means a non-zero winding number.
  // The mesh is copied into two uniform grids (columns over x-y for the winding number, cells for distances).
  static Result<Region> mesh(const TriMesh& mesh);

  Kind kind() const { return m_kind; }
  bool containsPoint(const Vec3d& p) const;
  // Mesh: the centre is inside and its distance to every triangle is >= r.
  bool containsSphere(const Vec3d& centre, double radius) const;
  Bounds bounds() const { return m_bounds; }
  // Box and cylinder: their volume. Mesh: the signed volume (> 0 for outward normals, < 0 for inward ones).
  double volume() const;
  // Uniform in bounds() (not necessarily inside the region).
  Vec3d samplePoint(Random& rng) const;

 private:
  struct MeshIndex;
  Kind m_kind = Kind::kBox;
  Bounds m_bounds;
  Vec3d m_base{0, 0, 0}, m_axis{0, 0, 1};  // cylinder
  double m_radius = 0, m_height = 0;       // cylinder
  std::shared_ptr<const MeshIndex> m_mesh;
};

}  // namespace pflow::frontend
