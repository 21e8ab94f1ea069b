// A triangle mesh as the front-end builds it: shared vertices, triangles by vertex index, and a
// local surface number per triangle (a box has 6 surfaces, a cylinder 3, ...). The scene loader
// renumbers surfaces scene-wide and turns a TriMesh into compute::MeshConfig.
//
// Orientation: the normal of triangle (a, b, c) is (b - a) x (c - a). Primitives are built as
// solids with outward normals; a container (particles inside) is the flipped solid, so that every
// normal points to the side the particles are on.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "compute/core/VectorMath.h"

namespace pflow::frontend {

struct TriMesh {
  std::vector<Vec3d> vertices;                          // [m]
  std::vector<std::array<std::uint32_t, 3>> triangles;  // vertex indices
  std::vector<std::int32_t> surface;                    // local surface number per triangle (same size as triangles)
  std::vector<std::string> surfaceNames;                // name of each local surface number ("side", "bottom", ...)

  std::size_t size() const { return triangles.size(); }
};

}  // namespace pflow::frontend
