// Tessellation of the geometric primitives a scene may use as walls: box, cylinder, cone/frustum,
// hopper and drum. Each is built as a solid: one vertex list shared by all its faces (neighbouring
// triangles share vertex indices, so shared corners are bit-identical), outward normals, and a
// local surface number per triangle. asContainer() flips a solid so particles can sit inside it.
// All lengths in metres, angles in radians. docs/geometry.md has the numbers (default resolution,
// area and volume errors).
#pragma once
#include <array>
#include <cstddef>
#include <numbers>

#include "common/Status.h"
#include "frontend/geometry/TriMesh.h"

namespace pflow::frontend {

// How finely curved and straight directions are cut.
//  - Around an axis: n = max(ceil(2 pi / maxAngle), ceil(sqrt2 * circumference / maxEdge)) segments
//    (at least 3), the same n at both ends of a frustum so its side is one clean strip.
//  - Along a straight direction of length L: ceil(sqrt2 * L / maxEdge) cells (1 when maxEdge = 0).
// The sqrt2 keeps the diagonal of each quad cell, and so every edge, within maxEdge (the rule the
// box has always used). Discs are filled with concentric rings of near-equilateral triangles.
struct Tessellation {
  double maxEdge = 0;                              // [m] longest triangle edge; 0 = no limit
  double maxAngle = 5.0 * std::numbers::pi / 180;  // [rad] angle subtended by one segment of a circle
};

// Hard limit on the triangles one primitive may produce: beyond it tessellate() fails (naming the
// count) instead of exhausting memory.
inline constexpr std::size_t kMaxPrimitiveTriangles = 10'000'000;

// Axis-aligned box. Surfaces: bottom (z = min) 0, top 1, left (x = min) 2, right 3, front (y = min) 4, back 5.
// Each face is a grid of cells no longer than maxEdge / sqrt2 per side, 2 triangles per cell.
struct BoxSpec {
  Vec3d min{0, 0, 0};
  Vec3d max{1, 1, 1};
  std::array<bool, 6> open{};  // per surface number: leave that face out
};

// Circular cylinder from `base` to base + height * axis. Surfaces: side 0, bottom cap 1, top cap 2.
struct CylinderSpec {
  Vec3d base{0, 0, 0};
  Vec3d axis{0, 0, 1};  // normalised by tessellate(); must not be zero
  double radius = 1;
  double height = 1;
  bool openBottom = false;
  bool openTop = false;
};

// Cone frustum from `base` (radius bottomRadius) to base + height * axis (radius topRadius). One of
// the radii may be 0: that end is an apex (no cap). Surfaces: side 0, bottom cap 1, top cap 2.
struct FrustumSpec {
  Vec3d base{0, 0, 0};
  Vec3d axis{0, 0, 1};
  double bottomRadius = 1;
  double topRadius = 0.5;
  double height = 1;
  bool openBottom = false;
  bool openTop = false;
};

// Hopper: a cone widening upwards from the orifice (radius orificeRadius at `orifice`) to topRadius
// at coneHeight, then an optional cylinder of topRadius and cylinderHeight above it.
// Surfaces: cone 0, cylinder 1, orifice cap 2, top cap 3. An open orifice is a hole with no triangles.
struct HopperSpec {
  Vec3d orifice{0, 0, 0};  // centre of the orifice (bottom of the cone)
  Vec3d axis{0, 0, 1};     // from the orifice up to the top
  double orificeRadius = 0.01;
  double topRadius = 0.05;
  double coneHeight = 0.05;
  double cylinderHeight = 0;  // 0 = no cylindrical section
  bool openOrifice = true;
  bool openTop = true;
};

// Closed rotating-drum shell: a cylinder of `length` centred at `centre`.
// Surfaces: shell 0, end cap at centre - length/2 axis 1, end cap at centre + length/2 axis 2.
struct DrumSpec {
  Vec3d centre{0, 0, 0};
  Vec3d axis{0, 0, 1};
  double radius = 1;
  double length = 1;
};

// Errors (invalid argument) name the offending parameter and its bound, e.g. "radius must be > 0, got -1".
Result<TriMesh> tessellate(const BoxSpec& spec, const Tessellation& tess = {});
Result<TriMesh> tessellate(const CylinderSpec& spec, const Tessellation& tess = {});
Result<TriMesh> tessellate(const FrustumSpec& spec, const Tessellation& tess = {});
Result<TriMesh> tessellate(const HopperSpec& spec, const Tessellation& tess = {});
Result<TriMesh> tessellate(const DrumSpec& spec, const Tessellation& tess = {});

// Segments around a circle of `radius` under `tess` (at least 3); the count tessellate() uses.
Result<std::size_t> circleSegments(double radius, const Tessellation& tess);

// The solid turned inside out: normals point inwards, to where the particles are. This is how a
// scene uses a primitive by default.
TriMesh asContainer(TriMesh solid);

}  // namespace pflow::frontend
