#include "frontend/geometry/MeshOps.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <unordered_map>

namespace pflow::frontend {
namespace {

Vec3d corner(const TriMesh& mesh, std::size_t t, int c) { return mesh.vertices[mesh.triangles[t][c]]; }

std::string str(const Vec3d& v) {
  std::ostringstream os;  // not operator+ chains: GCC 12 raises a false -Wrestrict on those
  os.precision(9);
  os << '(' << v.x << ", " << v.y << ", " << v.z << ')';
  return os.str();
}

// One directed use of an edge, keyed by its undirected vertex pair so both uses sort together.
struct EdgeUse {
  std::uint64_t key;    // (min << 32) | max
  bool forward;         // traversed min -> max
  std::uint32_t tri;
};

std::vector<EdgeUse> edgeUses(const TriMesh& mesh) {
  std::vector<EdgeUse> uses;
  uses.reserve(3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t a = mesh.triangles[t][c], b = mesh.triangles[t][(c + 1) % 3];
      const std::uint64_t lo = std::min(a, b), hi = std::max(a, b);
      uses.push_back({(lo << 32) | hi, a < b, static_cast<std::uint32_t>(t)});
    }
  }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return x.key != y.key ? x.key < y.key : x.tri < y.tri;
  });
  return uses;
}

std::string describeBadEdge(const EdgeUse* first, std::size_t count) {
  const auto a = static_cast<std::uint32_t>(first->key >> 32), b = static_cast<std::uint32_t>(first->key & 0xffffffffu);
  std::string s = "edge (" + std::to_string(a) + ", " + std::to_string(b) + ") of triangle " + std::to_string(first->tri);
  if (count == 1) return s + " has no neighbour (a hole or an open boundary)";
  if (count == 2) {
    return s + " is traversed in the same direction by triangles " + std::to_string(first[0].tri) + " and " +
           std::to_string(first[1].tri) + " (inconsistent orientation)";
  }
  return s + " is shared by " + std::to_string(count) + " triangles (non-manifold)";
}

// Hash of three 64-bit words (coordinates' bits or cell numbers); the mixing is splitmix64's.
struct Key3Hash {
  static std::uint64_t mix(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
  }
  std::size_t operator()(const std::array<std::uint64_t, 3>& k) const {
    return static_cast<std::size_t>(mix(k[0] ^ mix(k[1] ^ mix(k[2]))));
  }
};
using Key3 = std::array<std::uint64_t, 3>;

std::uint64_t bitsOf(double v) {
  v += 0.0;  // -0 becomes +0, so the two zeros weld
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

// representative[i] = the vertex that vertex i merges into (itself when it starts a cluster).
std::vector<std::uint32_t> exactRepresentatives(const std::vector<Vec3d>& v) {
  std::unordered_map<Key3, std::uint32_t, Key3Hash> seen;
  seen.reserve(v.size());
  std::vector<std::uint32_t> rep(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    rep[i] = seen.try_emplace(Key3{bitsOf(v[i].x), bitsOf(v[i].y), bitsOf(v[i].z)}, static_cast<std::uint32_t>(i)).first->second;
  }
  return rep;
}

std::vector<std::uint32_t> gridRepresentatives(const std::vector<Vec3d>& v, double tol) {
  constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  // Cells of 4 tol: the ball of radius tol around a vertex usually lies in its own cell, so most
  // vertices cost one lookup (at most 8 when it straddles cell faces).
  const double cell = 4 * tol;
  auto cellOf = [cell](double x) { return static_cast<std::int64_t>(std::floor(x / cell)); };
  auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return Key3{static_cast<std::uint64_t>(x), static_cast<std::uint64_t>(y), static_cast<std::uint64_t>(z)};
  };
  std::unordered_map<Key3, std::uint32_t, Key3Hash> head;  // cell -> last representative put there
  head.reserve(v.size());
  std::vector<std::uint32_t> next(v.size(), kNone);  // chain of representatives within a cell
  std::vector<std::uint32_t> rep(v.size());
  const double tol2 = tol * tol;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Vec3d p = v[i];
    std::uint32_t found = kNone;  // the lowest-numbered representative within tol
    for (std::int64_t cz = cellOf(p.z - tol); cz <= cellOf(p.z + tol); ++cz) {
      for (std::int64_t cy = cellOf(p.y - tol); cy <= cellOf(p.y + tol); ++cy) {
        for (std::int64_t cx = cellOf(p.x - tol); cx <= cellOf(p.x + tol); ++cx) {
          const auto it = head.find(key(cx, cy, cz));
          for (std::uint32_t j = it == head.end() ? kNone : it->second; j != kNone; j = next[j]) {
            if (norm2(v[j] - p) <= tol2 && j < found) found = j;
          }
        }
      }
    }
    if (found != kNone) {
      rep[i] = found;
      continue;
    }
    rep[i] = static_cast<std::uint32_t>(i);
    auto [it, inserted] = head.try_emplace(key(cellOf(p.x), cellOf(p.y), cellOf(p.z)), static_cast<std::uint32_t>(i));
    if (!inserted) {
      next[i] = it->second;
      it->second = static_cast<std::uint32_t>(i);
    }
  }
  return rep;
}

}  // namespace

Vec3d areaNormal(const TriMesh& mesh, std::size_t t) {
  const Vec3d a = corner(mesh, t, 0);
  return cross(corner(mesh, t, 1) - a, corner(mesh, t, 2) - a);
}

double area(const TriMesh& mesh) {
  double sum = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) sum += norm(areaNormal(mesh, t));
  return 0.5 * sum;
}

double signedVolume(const TriMesh& mesh) {
  // Divergence theorem: each triangle with the origin spans a tetrahedron of volume a . (b x c) / 6.
  // Measured from the first vertex instead of the origin, so a mesh far from the origin keeps its digits.
  if (mesh.vertices.empty()) return 0;
  const Vec3d o = mesh.vertices.front();
  double sum = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    sum += dot(corner(mesh, t, 0) - o, cross(corner(mesh, t, 1) - o, corner(mesh, t, 2) - o));
  }
  return sum / 6.0;
}

Aabb bounds(const TriMesh& mesh) {
  if (mesh.vertices.empty()) return {};
  Aabb box{mesh.vertices.front(), mesh.vertices.front()};
  for (const Vec3d& v : mesh.vertices) {
    box.lo = {std::min(box.lo.x, v.x), std::min(box.lo.y, v.y), std::min(box.lo.z, v.z)};
    box.hi = {std::max(box.hi.x, v.x), std::max(box.hi.y, v.y), std::max(box.hi.z, v.z)};
  }
  return box;
}

double longestEdge(const TriMesh& mesh) {
  double longest2 = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int c = 0; c < 3; ++c) longest2 = std::max(longest2, norm2(corner(mesh, t, (c + 1) % 3) - corner(mesh, t, c)));
  }
  return std::sqrt(longest2);
}

Status checkIndices(const TriMesh& mesh) {
  if (mesh.surface.size() != mesh.triangles.size()) {
    return invalidArgument("mesh has " + std::to_string(mesh.triangles.size()) + " triangles but " +
                           std::to_string(mesh.surface.size()) + " surface numbers (need one per triangle)");
  }
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (!isFinite(mesh.vertices[i])) return invalidArgument("vertex " + std::to_string(i) + " is not finite: " + str(mesh.vertices[i]));
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      if (mesh.triangles[t][c] >= mesh.vertices.size()) {
        return invalidArgument("triangle " + std::to_string(t) + " corner " + std::to_string(c) + ": vertex index " +
                               std::to_string(mesh.triangles[t][c]) + " >= vertex count " + std::to_string(mesh.vertices.size()));
      }
    }
  }
  return Status::ok();
}

Status checkClosed(const TriMesh& mesh) {
  if (Status s = checkIndices(mesh); !s) return s;
  if (mesh.triangles.empty()) return invalidArgument("mesh is not closed: it has no triangles");
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& [a, b, c] = mesh.triangles[t];
    if (a == b || b == c || c == a) {
      return invalidArgument("mesh is not closed: triangle " + std::to_string(t) + " repeats a vertex (" + std::to_string(a) +
                             ", " + std::to_string(b) + ", " + std::to_string(c) + ")");
    }
  }
  const std::vector<EdgeUse> uses = edgeUses(mesh);
  std::size_t bad = 0, edges = 0;
  const EdgeUse* firstBad = nullptr;  // the bad edge met first in triangle order
  std::size_t firstBadCount = 0;
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i + 1;
    while (j < uses.size() && uses[j].key == uses[i].key) ++j;
    ++edges;
    const bool ok = j - i == 2 && uses[i].forward != uses[i + 1].forward;
    if (!ok) {
      ++bad;
      if (!firstBad || uses[i].tri < firstBad->tri) {
        firstBad = &uses[i];
        firstBadCount = j - i;
      }
    }
    i = j;
  }
  if (bad == 0) return Status::ok();
  return invalidArgument("mesh is not closed: " + std::to_string(bad) + " of " + std::to_string(edges) +
                         " edges are not shared by exactly two oppositely oriented triangles; first: " +
                         describeBadEdge(firstBad, firstBadCount));
}

std::vector<std::size_t> degenerateTriangles(const TriMesh& mesh, double relTol) {
  std::vector<std::size_t> out;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& [a, b, c] = mesh.triangles[t];
    if (a == b || b == c || c == a) {
      out.push_back(t);
      continue;
    }
    double longest2 = 0;
    for (int k = 0; k < 3; ++k) longest2 = std::max(longest2, norm2(corner(mesh, t, (k + 1) % 3) - corner(mesh, t, k)));
    // 2 * area <= relTol * longest^2 (also catches NaN, whose comparison is false)
    if (!(norm(areaNormal(mesh, t)) > relTol * longest2)) out.push_back(t);
  }
  return out;
}

TriMesh flip(TriMesh mesh) {
  for (auto& tri : mesh.triangles) std::swap(tri[1], tri[2]);
  return mesh;
}

Result<TriMesh> transform(TriMesh mesh, double scale, Vec3d rotationAxis, double rotationAngle, Vec3d translation) {
  if (!(std::isfinite(scale) && scale > 0)) return invalidArgument("scale must be finite and > 0, got " + std::to_string(scale));
  if (!std::isfinite(rotationAngle)) return invalidArgument("rotation angle must be finite");
  if (!isFinite(translation)) return invalidArgument("translation must be finite, got " + str(translation));
  if (!isFinite(rotationAxis)) return invalidArgument("rotation axis must be finite, got " + str(rotationAxis));
  const double axisLength = norm(rotationAxis);
  const bool rotate = rotationAngle != 0;
  if (rotate && !(axisLength > 0)) return invalidArgument("rotation axis must have length > 0 when the rotation angle is not 0");
  const Vec3d k = rotate ? (1.0 / axisLength) * rotationAxis : Vec3d{0, 0, 1};
  for (Vec3d& v : mesh.vertices) {
    Vec3d x = scale * v;
    if (rotate) x = rotateAbout(x, k, rotationAngle);
    v = x + translation;
  }
  return mesh;
}

TriMesh weldVertices(const TriMesh& mesh, double tol, WeldStats* stats) {
  const std::vector<std::uint32_t> rep = tol > 0 ? gridRepresentatives(mesh.vertices, tol) : exactRepresentatives(mesh.vertices);
  // New numbering: representatives that some kept triangle uses, in the order of their old index.
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> newIndex(mesh.vertices.size(), kUnused);
  TriMesh out;
  out.surfaceNames = mesh.surfaceNames;
  out.triangles.reserve(mesh.triangles.size());
  out.surface.reserve(mesh.triangles.size());
  std::size_t collapsed = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    std::array<std::uint32_t, 3> tri{rep[mesh.triangles[t][0]], rep[mesh.triangles[t][1]], rep[mesh.triangles[t][2]]};
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) {
      ++collapsed;
      continue;
    }
    for (auto& v : tri) newIndex[v] = 0;  // mark used; numbered below
    out.triangles.push_back(tri);
    out.surface.push_back(t < mesh.surface.size() ? mesh.surface[t] : 0);
  }
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (newIndex[i] == kUnused) continue;
    newIndex[i] = static_cast<std::uint32_t>(out.vertices.size());
    out.vertices.push_back(mesh.vertices[i]);
  }
  for (auto& tri : out.triangles) {
    for (auto& v : tri) v = newIndex[v];
  }
  if (stats) {
    stats->mergedVertices = mesh.vertices.size() - out.vertices.size();
    stats->collapsedTriangles = collapsed;
  }
  return out;
}

}  // namespace pflow::frontend
