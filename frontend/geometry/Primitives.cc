#include "frontend/geometry/Primitives.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <numbers>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "frontend/geometry/MeshOps.h"

namespace pflow::frontend {
namespace {

using Ring = std::vector<std::uint32_t>;  // vertex indices around a circle, counter-clockwise about the axis

constexpr double kSqrt2 = std::numbers::sqrt2;
// ceil() of a count computed in floating point: 2 pi / (5 degrees) is 72 up to rounding, not 73.
constexpr double kCountSlack = 1e-9;

std::string num(double v) {
  std::ostringstream os;
  os.precision(9);
  os << v;
  return os.str();
}

std::string vec(const Vec3d& v) {
  std::ostringstream os;
  os.precision(9);
  os << '[' << v.x << ", " << v.y << ", " << v.z << ']';
  return os.str();
}

Status positive(const char* name, double v) {
  if (std::isfinite(v) && v > 0) return Status::ok();
  return invalidArgument(std::string(name) + " must be > 0 (and finite), got " + num(v));
}

Status nonNegative(const char* name, double v) {
  if (std::isfinite(v) && v >= 0) return Status::ok();
  return invalidArgument(std::string(name) + " must be >= 0 (and finite), got " + num(v));
}

Status finitePoint(const char* name, const Vec3d& p) {
  if (isFinite(p)) return Status::ok();
  return invalidArgument(std::string(name) + " must be finite, got " + vec(p));
}

Result<Vec3d> unitAxis(const Vec3d& axis) {
  const double length = norm(axis);
  if (!isFinite(axis) || !(length > 0)) return invalidArgument("axis must be a finite vector of length > 0, got " + vec(axis));
  return (1.0 / length) * axis;
}

Status checkTessellation(const Tessellation& tess) {
  if (Status s = nonNegative("tessellation maxEdge", tess.maxEdge); !s) return s;
  if (!(std::isfinite(tess.maxAngle) && tess.maxAngle > 0 && tess.maxAngle <= std::numbers::pi)) {
    return invalidArgument("tessellation maxAngle must be in (0, pi] rad, got " + num(tess.maxAngle));
  }
  return Status::ok();
}

Status checkBudget(double triangles) {
  if (triangles <= static_cast<double>(kMaxPrimitiveTriangles)) return Status::ok();
  std::ostringstream os;
  os << std::fixed << std::setprecision(0) << "tessellation would make " << std::ceil(triangles) << " triangles, more than the limit of "
     << kMaxPrimitiveTriangles << "; increase maxEdge or maxAngle";
  return {StatusCode::kResourceExhausted, os.str()};
}

// Cells along a straight direction of `length`: no side longer than maxEdge / sqrt2, so the cell
// diagonal stays within maxEdge. Returned as double so callers can check the budget before casting.
double straightCells(double length, const Tessellation& tess) {
  if (!(tess.maxEdge > 0)) return 1;
  return std::max(1.0, std::ceil(kSqrt2 * length / tess.maxEdge - kCountSlack));
}

double circleSegmentsRaw(double radius, const Tessellation& tess) {
  double n = std::ceil(2 * std::numbers::pi / tess.maxAngle - kCountSlack);
  if (tess.maxEdge > 0) n = std::max(n, std::ceil(kSqrt2 * 2 * std::numbers::pi * radius / tess.maxEdge - kCountSlack));
  return std::max(3.0, n);
}

// Rings of a disc of `segments` outer vertices: radial spacing ~ sqrt3/2 of the outer arc spacing,
// so the triangles between rings are near equilateral.
std::size_t discRings(std::size_t segments) {
  const double arcOverRadius = 2 * std::numbers::pi / static_cast<double>(segments);
  return static_cast<std::size_t>(std::max(1.0, std::ceil(1.0 / (arcOverRadius * std::sqrt(3.0) / 2) - kCountSlack)));
}

// Vertices on ring k of m inside a disc whose outer ring has n: proportional to the radius.
std::size_t discRingSegments(std::size_t n, std::size_t k, std::size_t m) {
  if (k == m) return n;
  return std::max<std::size_t>(3, (n * k + m - 1) / m);
}

double discTriangles(std::size_t n) {
  const std::size_t m = discRings(n);
  double count = 0;
  for (std::size_t k = 1; k <= m; ++k) count += static_cast<double>(discRingSegments(n, k, m) + (k > 1 ? discRingSegments(n, k - 1, m) : 0));
  return count;
}

// Local frame of a body of revolution: e1, e2, axis right-handed; theta measured from e1 towards e2.
struct Frame {
  Vec3d origin, axis, e1, e2;

  static Frame make(const Vec3d& origin, const Vec3d& axis) {
    // Gram-Schmidt on the coordinate axis least aligned with `axis`: for axis = z this gives e1 = x, e2 = y.
    const double ax = std::abs(axis.x), ay = std::abs(axis.y), az = std::abs(axis.z);
    const Vec3d pick = (ax <= ay && ax <= az) ? Vec3d{1, 0, 0} : (ay <= az ? Vec3d{0, 1, 0} : Vec3d{0, 0, 1});
    Vec3d e1 = pick - dot(pick, axis) * axis;
    e1 = (1.0 / norm(e1)) * e1;
    return {origin, axis, e1, cross(axis, e1)};
  }
  Vec3d at(double z, double r, double theta) const {
    return origin + z * axis + (r * std::cos(theta)) * e1 + (r * std::sin(theta)) * e2;
  }
};

class Builder {
 public:
  explicit Builder(std::vector<std::string> names) { m_mesh.surfaceNames = std::move(names); }

  std::uint32_t vertex(const Vec3d& p) {
    m_mesh.vertices.push_back(p);
    return static_cast<std::uint32_t>(m_mesh.vertices.size() - 1);
  }
  void triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c, int surface) {
    m_mesh.triangles.push_back({a, b, c});
    m_mesh.surface.push_back(surface);
  }
  // Ring of n vertices (one, the apex, when r = 0) at axial position z.
  Ring ring(const Frame& f, double z, double r, std::size_t n, double phase = 0) {
    if (r == 0) return {vertex(f.at(z, 0, 0))};
    Ring out(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = vertex(f.at(z, r, phase + 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n)));
    return out;
  }

  // Side strip between a lower and an upper ring of equal size (or an apex of size 1), normals outward.
  void strip(const Ring& lower, const Ring& upper, int surface) {
    const std::size_t n = std::max(lower.size(), upper.size());
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t j = (i + 1) % n;
      if (lower.size() == 1) {
        triangle(lower[0], upper[j], upper[i], surface);
      } else if (upper.size() == 1) {
        triangle(lower[i], lower[j], upper[0], surface);
      } else {
        triangle(lower[i], lower[j], upper[j], surface);
        triangle(lower[i], upper[j], upper[i], surface);
      }
    }
  }

  // Annulus between an inner and an outer ring of any sizes, normals along +axis. Advances along
  // whichever ring gives the shorter new diagonal, which keeps the triangles well shaped.
  void stitch(const Ring& inner, const Ring& outer, int surface, bool flipNormal) {
    const std::size_t a = inner.size(), b = outer.size();
    auto P = [&](std::uint32_t v) { return m_mesh.vertices[v]; };
    std::size_t i = 0, j = 0;
    while (i < a || j < b) {
      const std::uint32_t in = inner[i % a], out = outer[j % b];
      bool advanceInner;
      if (i == a) {
        advanceInner = false;
      } else if (j == b) {
        advanceInner = true;
      } else {
        advanceInner = norm2(P(inner[(i + 1) % a]) - P(out)) < norm2(P(outer[(j + 1) % b]) - P(in));
      }
      // (inner, outer, next) turns counter-clockwise about the axis whichever ring `next` is on.
      const std::uint32_t next = advanceInner ? inner[(i + 1) % a] : outer[(j + 1) % b];
      if (flipNormal) {
        triangle(in, next, out, surface);
      } else {
        triangle(in, out, next, surface);
      }
      (advanceInner ? i : j) += 1;
    }
  }

  // Disc filling `rim` (a ring of radius r at z) with concentric rings; normal +axis, or -axis when flipNormal.
  void disc(const Frame& f, double z, double r, const Ring& rim, int surface, bool flipNormal) {
    const std::size_t n = rim.size(), m = discRings(n);
    Ring previous{vertex(f.at(z, 0, 0))};
    for (std::size_t k = 1; k <= m; ++k) {
      // Inner rings are staggered by half a segment against their neighbours' alignment.
      Ring current = k == m ? rim
                            : ring(f, z, r * static_cast<double>(k) / static_cast<double>(m), discRingSegments(n, k, m),
                                   (k % 2) * std::numbers::pi / static_cast<double>(discRingSegments(n, k, m)));
      if (previous.size() == 1) {
        for (std::size_t i = 0; i < current.size(); ++i) {
          const std::uint32_t c = previous[0], p = current[i], q = current[(i + 1) % current.size()];
          flipNormal ? triangle(c, q, p, surface) : triangle(c, p, q, surface);
        }
      } else {
        stitch(previous, current, surface, flipNormal);
      }
      previous = std::move(current);
    }
  }

  TriMesh take() { return std::move(m_mesh); }

 private:
  TriMesh m_mesh;
};

// Rings from (z0, r0) to (z1, r1) inclusive, `rows` cells apart; the first ring is given.
std::vector<Ring> sideRings(Builder& b, const Frame& f, Ring first, double z0, double r0, double z1, double r1, std::size_t rows,
                            std::size_t n) {
  std::vector<Ring> rings{std::move(first)};
  for (std::size_t k = 1; k <= rows; ++k) {
    const double s = static_cast<double>(k) / static_cast<double>(rows);
    // The last ring is placed at exactly (z1, r1), not z0 + 1.0 * (z1 - z0), so caps and the next section agree.
    const double z = k == rows ? z1 : z0 + s * (z1 - z0);
    const double r = k == rows ? r1 : r0 + s * (r1 - r0);
    rings.push_back(b.ring(f, z, r, n));
  }
  return rings;
}

void sideStrips(Builder& b, const std::vector<Ring>& rings, int surface) {
  for (std::size_t k = 0; k + 1 < rings.size(); ++k) b.strip(rings[k], rings[k + 1], surface);
}

// --- the box --------------------------------------------------------------------------------------------------------

struct BoxFace {
  std::array<int, 3> origin;  // lattice corner as (0 or 1) per axis: 0 = min, 1 = max
  int u, v;                   // lattice axes spanned; outward normal = v x u
};
// Order = surface number. The grid is the one the scene loader has always built (U x V into the box).
constexpr std::array<BoxFace, 6> kBoxFaces{{
    {{0, 0, 0}, 0, 1},  // bottom
    {{0, 0, 1}, 1, 0},  // top
    {{0, 0, 0}, 1, 2},  // left
    {{1, 0, 0}, 2, 1},  // right
    {{0, 0, 0}, 2, 0},  // front
    {{0, 1, 0}, 0, 2},  // back
}};

}  // namespace

Result<std::size_t> circleSegments(double radius, const Tessellation& tess) {
  if (Status s = checkTessellation(tess); !s) return s;
  if (Status s = nonNegative("radius", radius); !s) return s;
  const double n = circleSegmentsRaw(radius, tess);
  if (Status s = checkBudget(n); !s) return s;
  return static_cast<std::size_t>(n);
}

Result<TriMesh> tessellate(const BoxSpec& spec, const Tessellation& tess) {
  if (Status s = checkTessellation(tess); !s) return s;
  if (Status s = finitePoint("min", spec.min); !s) return s;
  if (Status s = finitePoint("max", spec.max); !s) return s;
  const std::array<double, 3> lo{spec.min.x, spec.min.y, spec.min.z}, hi{spec.max.x, spec.max.y, spec.max.z};
  for (int a = 0; a < 3; ++a) {
    if (!(hi[a] > lo[a])) return invalidArgument("max must be > min on every axis, got min " + vec(spec.min) + ", max " + vec(spec.max));
  }
  if (std::all_of(spec.open.begin(), spec.open.end(), [](bool o) { return o; })) return invalidArgument("open: all six faces open leaves no box");
  std::array<double, 3> cellsD{};
  for (int a = 0; a < 3; ++a) cellsD[a] = straightCells(hi[a] - lo[a], tess);
  double count = 0;
  for (std::size_t f = 0; f < 6; ++f) count += spec.open[f] ? 0 : 2 * cellsD[kBoxFaces[f].u] * cellsD[kBoxFaces[f].v];
  if (Status s = checkBudget(count); !s) return s;
  const std::array<std::size_t, 3> cells{static_cast<std::size_t>(cellsD[0]), static_cast<std::size_t>(cellsD[1]), static_cast<std::size_t>(cellsD[2])};

  // Vertices live on the box's lattice; faces meeting at an edge look up the same lattice points.
  // A coordinate depends only on its axis and lattice index, and the last index is exactly max.
  auto coord = [&](int a, std::size_t i) { return i == cells[a] ? hi[a] : lo[a] + (static_cast<double>(i) / static_cast<double>(cells[a])) * (hi[a] - lo[a]); };
  Builder b({"bottom", "top", "left", "right", "front", "back"});
  std::unordered_map<std::uint64_t, std::uint32_t> lattice;
  auto vertexAt = [&](const std::array<std::size_t, 3>& ijk) {
    const std::uint64_t key = (static_cast<std::uint64_t>(ijk[0]) << 42) | (static_cast<std::uint64_t>(ijk[1]) << 21) | ijk[2];
    auto it = lattice.find(key);
    if (it != lattice.end()) return it->second;
    const std::uint32_t v = b.vertex({coord(0, ijk[0]), coord(1, ijk[1]), coord(2, ijk[2])});
    lattice.emplace(key, v);
    return v;
  };
  for (std::size_t f = 0; f < 6; ++f) {
    if (spec.open[f]) continue;
    const BoxFace& face = kBoxFaces[f];
    auto vid = [&](std::size_t i, std::size_t j) {
      std::array<std::size_t, 3> ijk{};
      for (int a = 0; a < 3; ++a) ijk[a] = face.origin[a] ? cells[a] : 0;
      ijk[face.u] += i;
      ijk[face.v] += j;
      return vertexAt(ijk);
    };
    for (std::size_t j = 0; j < cells[face.v]; ++j) {
      for (std::size_t i = 0; i < cells[face.u]; ++i) {
        // Corners looked up in a fixed order (argument evaluation order is unspecified), so vertex numbering is portable.
        const std::uint32_t c00 = vid(i, j), c10 = vid(i + 1, j), c11 = vid(i + 1, j + 1), c01 = vid(i, j + 1);
        // The loader's inward pair (a, b, c), (a, c, d) with b and c swapped: outward, and asContainer() restores it.
        b.triangle(c00, c11, c10, static_cast<int>(f));
        b.triangle(c00, c01, c11, static_cast<int>(f));
      }
    }
  }
  return b.take();
}

Result<TriMesh> tessellate(const FrustumSpec& spec, const Tessellation& tess) {
  if (Status s = checkTessellation(tess); !s) return s;
  if (Status s = finitePoint("base", spec.base); !s) return s;
  auto axis = unitAxis(spec.axis);
  if (!axis) return axis.status();
  if (Status s = nonNegative("bottom_radius", spec.bottomRadius); !s) return s;
  if (Status s = nonNegative("top_radius", spec.topRadius); !s) return s;
  if (!(spec.bottomRadius > 0 || spec.topRadius > 0)) return invalidArgument("bottom_radius and top_radius must not both be 0");
  if (Status s = positive("height", spec.height); !s) return s;

  const double rMax = std::max(spec.bottomRadius, spec.topRadius);
  const double nD = circleSegmentsRaw(rMax, tess);
  const double rowsD = straightCells(std::hypot(spec.height, spec.topRadius - spec.bottomRadius), tess);
  if (Status s = checkBudget(2 * nD * rowsD); !s) return s;
  const auto n = static_cast<std::size_t>(nD), rows = static_cast<std::size_t>(rowsD);
  if (Status s = checkBudget(2 * nD * rowsD + 2 * discTriangles(n)); !s) return s;

  const Frame f = Frame::make(spec.base, *axis);
  Builder b({"side", "bottom", "top"});
  const std::vector<Ring> rings = sideRings(b, f, b.ring(f, 0, spec.bottomRadius, n), 0, spec.bottomRadius, spec.height, spec.topRadius, rows, n);
  sideStrips(b, rings, 0);
  if (!spec.openBottom && spec.bottomRadius > 0) b.disc(f, 0, spec.bottomRadius, rings.front(), 1, /*flipNormal=*/true);
  if (!spec.openTop && spec.topRadius > 0) b.disc(f, spec.height, spec.topRadius, rings.back(), 2, /*flipNormal=*/false);
  return b.take();
}

Result<TriMesh> tessellate(const CylinderSpec& spec, const Tessellation& tess) {
  if (Status s = positive("radius", spec.radius); !s) return s;
  return tessellate(FrustumSpec{spec.base, spec.axis, spec.radius, spec.radius, spec.height, spec.openBottom, spec.openTop}, tess);
}

Result<TriMesh> tessellate(const HopperSpec& spec, const Tessellation& tess) {
  if (Status s = checkTessellation(tess); !s) return s;
  if (Status s = finitePoint("orifice", spec.orifice); !s) return s;
  auto axis = unitAxis(spec.axis);
  if (!axis) return axis.status();
  if (Status s = positive("orifice_radius", spec.orificeRadius); !s) return s;
  if (Status s = positive("top_radius", spec.topRadius); !s) return s;
  if (!(spec.orificeRadius < spec.topRadius)) {
    return invalidArgument("orifice_radius must be < top_radius (" + num(spec.topRadius) + "), got " + num(spec.orificeRadius));
  }
  if (Status s = positive("cone_height", spec.coneHeight); !s) return s;
  if (Status s = nonNegative("cylinder_height", spec.cylinderHeight); !s) return s;

  const double nD = circleSegmentsRaw(spec.topRadius, tess);
  const double coneRowsD = straightCells(std::hypot(spec.coneHeight, spec.topRadius - spec.orificeRadius), tess);
  const double cylRowsD = spec.cylinderHeight > 0 ? straightCells(spec.cylinderHeight, tess) : 0;
  if (Status s = checkBudget(2 * nD * (coneRowsD + cylRowsD)); !s) return s;
  const auto n = static_cast<std::size_t>(nD);
  if (Status s = checkBudget(2 * nD * (coneRowsD + cylRowsD) + 2 * discTriangles(n)); !s) return s;

  const Frame f = Frame::make(spec.orifice, *axis);
  Builder b({"cone", "cylinder", "orifice", "top"});
  const double zTop = spec.coneHeight + spec.cylinderHeight;
  const std::vector<Ring> cone = sideRings(b, f, b.ring(f, 0, spec.orificeRadius, n), 0, spec.orificeRadius, spec.coneHeight,
                                           spec.topRadius, static_cast<std::size_t>(coneRowsD), n);
  sideStrips(b, cone, 0);
  Ring top = cone.back();
  if (spec.cylinderHeight > 0) {
    const std::vector<Ring> cyl = sideRings(b, f, cone.back(), spec.coneHeight, spec.topRadius, zTop, spec.topRadius,
                                            static_cast<std::size_t>(cylRowsD), n);
    sideStrips(b, cyl, 1);
    top = cyl.back();
  }
  if (!spec.openOrifice) b.disc(f, 0, spec.orificeRadius, cone.front(), 2, /*flipNormal=*/true);
  if (!spec.openTop) b.disc(f, zTop, spec.topRadius, top, 3, /*flipNormal=*/false);
  return b.take();
}

Result<TriMesh> tessellate(const DrumSpec& spec, const Tessellation& tess) {
  if (Status s = finitePoint("centre", spec.centre); !s) return s;
  auto axis = unitAxis(spec.axis);
  if (!axis) return axis.status();
  if (Status s = positive("radius", spec.radius); !s) return s;
  if (Status s = positive("length", spec.length); !s) return s;
  auto mesh = tessellate(CylinderSpec{spec.centre - (0.5 * spec.length) * *axis, *axis, spec.radius, spec.length, false, false}, tess);
  if (mesh) mesh->surfaceNames = {"shell", "end1", "end2"};
  return mesh;
}

TriMesh asContainer(TriMesh solid) { return flip(std::move(solid)); }

}  // namespace pflow::frontend
