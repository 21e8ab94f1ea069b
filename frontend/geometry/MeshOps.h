// Measurements, checks and edits of a TriMesh: what the tessellator, the mesh file readers and the
// scene loader need to trust a mesh before the DEM core sees it.
#pragma once
#include <cstddef>
#include <vector>

#include "common/Status.h"
#include "frontend/geometry/TriMesh.h"

namespace pflow::frontend {

struct Aabb {
  Vec3d lo{0, 0, 0};  // [m]
  Vec3d hi{0, 0, 0};  // [m]
};

// A triangle counts as degenerate when two corners share an index or when its area is below
// this fraction of the square of its longest edge (sine of the smallest angle ~ 2e-10).
inline constexpr double kDegenerateRelTol = 1e-10;

// Normal of triangle t scaled by twice its area, (b - a) x (c - a) [m^2].
Vec3d areaNormal(const TriMesh& mesh, std::size_t t);

double area(const TriMesh& mesh);          // [m^2]
double signedVolume(const TriMesh& mesh);  // [m^3]; > 0 for a closed mesh with outward normals
Aabb bounds(const TriMesh& mesh);          // of the vertices; lo = hi = 0 for an empty mesh
double longestEdge(const TriMesh& mesh);   // [m]

// Structural sanity: surface list as long as the triangle list, every index below the vertex
// count, every coordinate finite. The message names the first offender.
Status checkIndices(const TriMesh& mesh);

// Watertight and consistently oriented: every edge is used by exactly two triangles, once in each
// direction. The message names the first bad edge (vertex indices) and how many edges are bad.
Status checkClosed(const TriMesh& mesh);

// Indices of degenerate triangles (see kDegenerateRelTol), in order.
std::vector<std::size_t> degenerateTriangles(const TriMesh& mesh, double relTol = kDegenerateRelTol);

// Reverses the orientation of every triangle (normals point the other way).
TriMesh flip(TriMesh mesh);

// x -> R (scale x) + translation, R the rotation by `rotationAngle` [rad] about `rotationAxis`
// (any length > 0; ignored when the angle is 0). scale must be finite and > 0 (a negative scale
// would turn the mesh inside out).
Result<TriMesh> transform(TriMesh mesh, double scale, Vec3d rotationAxis, double rotationAngle, Vec3d translation);

struct WeldStats {
  std::size_t mergedVertices = 0;       // vertices removed
  std::size_t collapsedTriangles = 0;   // triangles dropped because two corners merged
};

// Merges vertices closer than `tol` [m] (tol = 0: bit-identical coordinates only, with -0 == +0).
// Keeps the first vertex of each cluster and the order of first appearance; unused vertices are
// dropped; triangles whose corners merge are dropped. O(n) with a hash grid of cell size tol.
TriMesh weldVertices(const TriMesh& mesh, double tol, WeldStats* stats = nullptr);

}  // namespace pflow::frontend
