// Tessellated primitives and mesh operations: closed, outward, accurate, within maxEdge, numbered.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include "frontend/geometry/MeshOps.h"
#include "frontend/geometry/Primitives.h"

namespace pflow::frontend {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kShapeTol = 0.005;  // area and volume within 0.5 % of the analytic solid at the default tessellation

Vec3d unit(Vec3d v) { return (1.0 / norm(v)) * v; }
Vec3d centroid(const TriMesh& m, std::size_t t) {
  return (1.0 / 3.0) * (m.vertices[m.triangles[t][0]] + m.vertices[m.triangles[t][1]] + m.vertices[m.triangles[t][2]]);
}

// Directed edges used once: the boundary of an open mesh (empty for a closed one).
std::vector<std::pair<std::uint32_t, std::uint32_t>> boundaryEdges(const TriMesh& m) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> count;
  for (const auto& t : m.triangles) {
    for (int c = 0; c < 3; ++c) ++count[{std::min(t[c], t[(c + 1) % 3]), std::max(t[c], t[(c + 1) % 3])}];
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
  for (const auto& [e, n] : count) {
    if (n == 1) out.push_back(e);
  }
  return out;
}

// Distance from the axis line through `o` and its coordinate along the axis.
double radial(Vec3d p, Vec3d o, Vec3d axis) {
  const Vec3d d = p - o;
  return norm(d - dot(d, axis) * axis);
}
double axial(Vec3d p, Vec3d o, Vec3d axis) { return dot(p - o, axis); }

// Every triangle of a body of revolution faces out: side surfaces away from the axis, caps along
// -axis at the bottom and +axis at the top.
void expectOutwardRevolution(const TriMesh& m, Vec3d o, Vec3d axis, const std::set<int>& sides, int bottom, int top) {
  for (std::size_t t = 0; t < m.size(); ++t) {
    const Vec3d n = unit(areaNormal(m, t));
    const Vec3d c = centroid(m, t);
    const Vec3d d = c - o;
    const Vec3d outward = unit(d - dot(d, axis) * axis);
    const int s = m.surface[t];
    if (sides.count(s)) {
      ASSERT_GT(dot(n, outward), 0.0) << "side triangle " << t << " faces the axis";
    } else if (s == bottom) {
      ASSERT_LT(dot(n, axis), -0.999999) << "bottom cap triangle " << t;
    } else if (s == top) {
      ASSERT_GT(dot(n, axis), 0.999999) << "top cap triangle " << t;
    } else {
      FAIL() << "unexpected surface " << s;
    }
  }
}

void expectClosedSolid(const TriMesh& m, double areaExact, double volumeExact) {
  const Status closed = checkClosed(m);
  ASSERT_TRUE(closed.isOk()) << closed.message();
  EXPECT_GT(signedVolume(m), 0.0);
  EXPECT_NEAR(signedVolume(m) / volumeExact, 1.0, kShapeTol);
  EXPECT_NEAR(area(m) / areaExact, 1.0, kShapeTol);
  EXPECT_TRUE(degenerateTriangles(m).empty());
  EXPECT_NEAR(signedVolume(asContainer(m)), -signedVolume(m), 1e-12 * std::abs(signedVolume(m)));
}

double minAngleDeg(const TriMesh& m, int surface) {
  double worst = 180;
  for (std::size_t t = 0; t < m.size(); ++t) {
    if (m.surface[t] != surface) continue;
    for (int c = 0; c < 3; ++c) {
      const Vec3d a = m.vertices[m.triangles[t][c]], b = m.vertices[m.triangles[t][(c + 1) % 3]], d = m.vertices[m.triangles[t][(c + 2) % 3]];
      worst = std::min(worst, std::acos(std::clamp(dot(unit(b - a), unit(d - a)), -1.0, 1.0)) * 180 / kPi);
    }
  }
  return worst;
}

std::set<int> surfacesOf(const TriMesh& m) { return {m.surface.begin(), m.surface.end()}; }

// --- box --------------------------------------------------------------------------------------------------------------

TEST(Box, ClosedOutwardExact) {
  const BoxSpec spec{{-0.1, 0.2, 0.3}, {0.4, 0.45, 1.3}, {}};
  auto m = tessellate(spec, Tessellation{.maxEdge = 0.1});
  ASSERT_TRUE(m.isOk()) << m.status().message();
  const double a = 0.5, b = 0.25, c = 1.0;
  expectClosedSolid(*m, 2 * (a * b + b * c + c * a), a * b * c);
  EXPECT_NEAR(area(*m), 2 * (a * b + b * c + c * a), 1e-12);
  EXPECT_NEAR(signedVolume(*m), a * b * c, 1e-12);
  EXPECT_LE(longestEdge(*m), 0.1 * (1 + 1e-12));
  const std::array<Vec3d, 6> outward{{{0, 0, -1}, {0, 0, 1}, {-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}}};
  for (std::size_t t = 0; t < m->size(); ++t) {
    EXPECT_GT(dot(unit(areaNormal(*m, t)), outward[m->surface[t]]), 0.999999) << "triangle " << t;
  }
  EXPECT_EQ(m->surfaceNames, (std::vector<std::string>{"bottom", "top", "left", "right", "front", "back"}));
}

TEST(Box, SharedVerticesOnly) {
  // 2 x 2 x 2 cells: a closed lattice surface has 6 * 4 + 2 = 26 vertices if every edge vertex is shared.
  auto m = tessellate(BoxSpec{{0, 0, 0}, {1, 1, 1}, {}}, Tessellation{.maxEdge = std::sqrt(2.0) / 2});
  ASSERT_TRUE(m.isOk());
  EXPECT_EQ(m->vertices.size(), 26u);
  EXPECT_EQ(m->size(), 48u);
}

// The loader's box (frontend/SceneLoader.cc, makeBoxMesh) as it has always been built: per face a
// grid of cells of at most resolution / sqrt2, U x V into the box. Reproduced here to check that
// asContainer(tessellate(box)) is the same mesh, triangle by triangle.
std::vector<std::array<Vec3d, 3>> loaderBox(Vec3d lo, Vec3d hi, std::array<bool, 6> open, double resolution, std::vector<int>& surface) {
  const Vec3d d = hi - lo;
  const Vec3d ex{d.x, 0, 0}, ey{0, d.y, 0}, ez{0, 0, d.z};
  const std::array<std::array<Vec3d, 3>, 6> faces = {{{lo, ex, ey},
                                                      {Vec3d{lo.x, lo.y, hi.z}, ey, ex},
                                                      {lo, ey, ez},
                                                      {Vec3d{hi.x, lo.y, lo.z}, ez, ey},
                                                      {lo, ez, ex},
                                                      {Vec3d{lo.x, hi.y, lo.z}, ex, ez}}};
  std::vector<std::array<Vec3d, 3>> tris;
  for (std::size_t f = 0; f < 6; ++f) {
    if (open[f]) continue;
    const auto& [o, u, v] = faces[f];
    auto cells = [&](const Vec3d& e) {
      return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(norm(e) * std::sqrt(2.0) / resolution - 1e-9)));
    };
    const std::size_t nu = cells(u), nv = cells(v);
    auto p = [&](std::size_t i, std::size_t j) { return o + (static_cast<double>(i) / nu) * u + (static_cast<double>(j) / nv) * v; };
    for (std::size_t j = 0; j < nv; ++j) {
      for (std::size_t i = 0; i < nu; ++i) {
        tris.push_back({p(i, j), p(i + 1, j), p(i + 1, j + 1)});
        tris.push_back({p(i, j), p(i + 1, j + 1), p(i, j + 1)});
        surface.push_back(static_cast<int>(f));
        surface.push_back(static_cast<int>(f));
      }
    }
  }
  return tris;
}

TEST(Box, ContainerMatchesTheSceneLoaderBox) {
  const Vec3d lo{0.01, -0.02, 0}, hi{0.11, 0.05, 0.23};
  const std::array<bool, 6> open{false, true, false, false, true, false};  // top and front open
  for (double resolution : {0.02, 0.037, 1.0}) {
    std::vector<int> surface;
    const auto expected = loaderBox(lo, hi, open, resolution, surface);
    auto m = tessellate(BoxSpec{lo, hi, open}, Tessellation{.maxEdge = resolution});
    ASSERT_TRUE(m.isOk());
    const TriMesh c = asContainer(*m);
    ASSERT_EQ(c.size(), expected.size()) << "resolution " << resolution;
    for (std::size_t t = 0; t < c.size(); ++t) {
      EXPECT_EQ(c.surface[t], surface[t]);
      for (int k = 0; k < 3; ++k) {
        EXPECT_LT(norm(c.vertices[c.triangles[t][k]] - expected[t][k]), 1e-15) << "triangle " << t << " corner " << k;
      }
    }
    // The open faces leave exactly their rims as boundary.
    EXPECT_FALSE(checkClosed(*m).isOk());
  }
}

TEST(Box, Errors) {
  auto flat = tessellate(BoxSpec{{0, 0, 0}, {1, 1, 0}, {}});
  ASSERT_FALSE(flat.isOk());
  EXPECT_NE(flat.status().message().find("max must be > min"), std::string::npos) << flat.status().message();
  std::array<bool, 6> all;
  all.fill(true);
  EXPECT_FALSE(tessellate(BoxSpec{{0, 0, 0}, {1, 1, 1}, all}).isOk());
  EXPECT_FALSE(tessellate(BoxSpec{{0, 0, NAN}, {1, 1, 1}, {}}).isOk());
  auto tooFine = tessellate(BoxSpec{{0, 0, 0}, {1, 1, 1}, {}}, Tessellation{.maxEdge = 1e-4});
  ASSERT_FALSE(tooFine.isOk());
  EXPECT_EQ(tooFine.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(tooFine.status().message().find("would make 2400293388 triangles"), std::string::npos) << tooFine.status().message();
}

// --- cylinder, frustum, drum --------------------------------------------------------------------------------------------

TEST(Cylinder, ClosedAtDefaultTessellation) {
  const Vec3d base{0.3, -0.2, 0.1}, axis = unit({1, 2, 3});
  const double r = 0.05, h = 0.2;
  auto m = tessellate(CylinderSpec{base, {1, 2, 3}, r, h, false, false});
  ASSERT_TRUE(m.isOk()) << m.status().message();
  expectClosedSolid(*m, 2 * kPi * r * h + 2 * kPi * r * r, kPi * r * r * h);
  expectOutwardRevolution(*m, base, axis, {0}, 1, 2);
  EXPECT_EQ(surfacesOf(*m), (std::set<int>{0, 1, 2}));
  EXPECT_EQ(m->surfaceNames, (std::vector<std::string>{"side", "bottom", "top"}));
  // 72 segments (5 degrees), one row of side cells: 144 side triangles.
  EXPECT_EQ(std::count(m->surface.begin(), m->surface.end(), 0), 144);
  // Concentric rings keep the caps free of slivers.
  EXPECT_GT(minAngleDeg(*m, 1), 30.0);
  EXPECT_GT(minAngleDeg(*m, 2), 30.0);
}

TEST(Cylinder, MaxEdgeRespected) {
  for (double maxEdge : {0.2, 0.013, 0.004}) {
    auto m = tessellate(CylinderSpec{{0, 0, 0}, {0, 0, 1}, 0.05, 0.12, false, false}, {maxEdge, 5 * kPi / 180});
    ASSERT_TRUE(m.isOk());
    EXPECT_TRUE(checkClosed(*m).isOk());
    EXPECT_LE(longestEdge(*m), maxEdge * (1 + 1e-12)) << "maxEdge " << maxEdge;
    EXPECT_GT(minAngleDeg(*m, 1), 25.0) << "maxEdge " << maxEdge;
  }
}

TEST(Cylinder, OpenEndsLeaveRims) {
  auto m = tessellate(CylinderSpec{{0, 0, 0}, {0, 0, 1}, 0.05, 0.1, true, false});
  ASSERT_TRUE(m.isOk());
  const auto rim = boundaryEdges(*m);
  EXPECT_EQ(rim.size(), 72u);
  for (const auto& [a, b] : rim) {
    EXPECT_NEAR(m->vertices[a].z, 0.0, 1e-15);
    EXPECT_NEAR(std::hypot(m->vertices[a].x, m->vertices[a].y), 0.05, 1e-15);
  }
  EXPECT_EQ(surfacesOf(*m), (std::set<int>{0, 2}));
}

TEST(Cylinder, FineResolutionWithinTheCap) {
  auto m = tessellate(CylinderSpec{{0, 0, 0}, {0, 0, 1}, 0.1, 0.2, false, false}, {1e-3, 5 * kPi / 180});
  ASSERT_TRUE(m.isOk()) << m.status().message();
  EXPECT_GT(m->size(), 500'000u);
  EXPECT_LE(m->size(), kMaxPrimitiveTriangles);
  EXPECT_TRUE(checkClosed(*m).isOk());
  EXPECT_LE(longestEdge(*m), 1e-3 * (1 + 1e-12));
  auto tooFine = tessellate(CylinderSpec{{0, 0, 0}, {0, 0, 1}, 0.1, 0.2, false, false}, {1e-5, 5 * kPi / 180});
  ASSERT_FALSE(tooFine.isOk());
  EXPECT_NE(tooFine.status().message().find("triangles, more than the limit of 10000000"), std::string::npos) << tooFine.status().message();
}

TEST(Cylinder, Errors) {
  auto r = tessellate(CylinderSpec{{0, 0, 0}, {0, 0, 1}, -1, 1, false, false});
  ASSERT_FALSE(r.isOk());
  EXPECT_EQ(r.status().message(), "radius must be > 0 (and finite), got -1");
  auto a = tessellate(CylinderSpec{{0, 0, 0}, {0, 0, 0}, 1, 1, false, false});
  ASSERT_FALSE(a.isOk());
  EXPECT_NE(a.status().message().find("axis must be a finite vector of length > 0"), std::string::npos);
  auto h = tessellate(CylinderSpec{{0, 0, 0}, {0, 0, 1}, 1, NAN, false, false});
  ASSERT_FALSE(h.isOk());
  EXPECT_NE(h.status().message().find("height must be > 0"), std::string::npos) << h.status().message();
  auto t = tessellate(CylinderSpec{}, {-1, 0.1});
  ASSERT_FALSE(t.isOk());
  EXPECT_NE(t.status().message().find("maxEdge must be >= 0"), std::string::npos);
}

TEST(Frustum, ClosedAtDefaultTessellation) {
  const double r1 = 0.08, r2 = 0.03, h = 0.1;
  const Vec3d base{0, 0, 1};
  auto m = tessellate(FrustumSpec{base, {0, -1, 0}, r1, r2, h, false, false});
  ASSERT_TRUE(m.isOk()) << m.status().message();
  const double slant = std::hypot(h, r1 - r2);
  expectClosedSolid(*m, kPi * (r1 + r2) * slant + kPi * (r1 * r1 + r2 * r2), kPi * h / 3 * (r1 * r1 + r1 * r2 + r2 * r2));
  expectOutwardRevolution(*m, base, {0, -1, 0}, {0}, 1, 2);
}

TEST(Frustum, ConeWithApex) {
  const double r = 0.05, h = 0.12;
  for (bool apexOnTop : {true, false}) {
    auto m = tessellate(FrustumSpec{{0, 0, 0}, {0, 0, 1}, apexOnTop ? r : 0, apexOnTop ? 0 : r, h, false, false}, {0.02, 5 * kPi / 180});
    ASSERT_TRUE(m.isOk()) << m.status().message();
    expectClosedSolid(*m, kPi * r * std::hypot(r, h) + kPi * r * r, kPi * r * r * h / 3);
    EXPECT_LE(longestEdge(*m), 0.02 * (1 + 1e-12));
  }
  auto none = tessellate(FrustumSpec{{0, 0, 0}, {0, 0, 1}, 0, 0, 1, false, false});
  ASSERT_FALSE(none.isOk());
  EXPECT_NE(none.status().message().find("bottom_radius and top_radius must not both be 0"), std::string::npos);
}

TEST(Drum, ClosedAndCentred) {
  const Vec3d c{1, 2, 3};
  const double r = 0.2, L = 0.1;
  auto m = tessellate(DrumSpec{c, {1, 0, 0}, r, L});
  ASSERT_TRUE(m.isOk()) << m.status().message();
  expectClosedSolid(*m, 2 * kPi * r * L + 2 * kPi * r * r, kPi * r * r * L);
  expectOutwardRevolution(*m, c, {1, 0, 0}, {0}, 1, 2);
  const Aabb box = bounds(*m);
  EXPECT_NEAR(box.lo.x, c.x - L / 2, 1e-15);
  EXPECT_NEAR(box.hi.x, c.x + L / 2, 1e-15);
  EXPECT_EQ(m->surfaceNames, (std::vector<std::string>{"shell", "end1", "end2"}));
  auto bad = tessellate(DrumSpec{c, {1, 0, 0}, r, 0});
  ASSERT_FALSE(bad.isOk());
  EXPECT_EQ(bad.status().message(), "length must be > 0 (and finite), got 0");
}

// --- hopper -------------------------------------------------------------------------------------------------------------

HopperSpec hopperSpec() { return {{0.1, 0.1, 0.2}, {0, 0, 1}, 0.01, 0.05, 0.06, 0.04, true, true}; }

TEST(Hopper, ClosedAtDefaultTessellation) {
  HopperSpec s = hopperSpec();
  s.openOrifice = s.openTop = false;
  auto m = tessellate(s);
  ASSERT_TRUE(m.isOk()) << m.status().message();
  const double r0 = s.orificeRadius, R = s.topRadius, hc = s.coneHeight, hy = s.cylinderHeight;
  const double areaExact = kPi * (r0 + R) * std::hypot(hc, R - r0) + 2 * kPi * R * hy + kPi * (r0 * r0 + R * R);
  const double volumeExact = kPi * hc / 3 * (r0 * r0 + r0 * R + R * R) + kPi * R * R * hy;
  expectClosedSolid(*m, areaExact, volumeExact);
  expectOutwardRevolution(*m, s.orifice, s.axis, {0, 1}, 2, 3);
  EXPECT_EQ(surfacesOf(*m), (std::set<int>{0, 1, 2, 3}));
  EXPECT_EQ(m->surfaceNames, (std::vector<std::string>{"cone", "cylinder", "orifice", "top"}));
}

TEST(Hopper, OpenOrificeIsAHoleOfOrificeRadius) {
  const HopperSpec s = hopperSpec();
  auto m = tessellate(s, {0.01, 5 * kPi / 180});
  ASSERT_TRUE(m.isOk()) << m.status().message();
  EXPECT_LE(longestEdge(*m), 0.01 * (1 + 1e-12));
  EXPECT_EQ(surfacesOf(*m), (std::set<int>{0, 1}));
  // Two boundary loops: the orifice (radius r0 at the orifice plane) and the top rim.
  std::size_t orifice = 0, top = 0;
  for (const auto& [a, b] : boundaryEdges(*m)) {
    for (std::uint32_t v : {a, b}) {
      const Vec3d p = m->vertices[v];
      const double z = axial(p, s.orifice, s.axis), r = radial(p, s.orifice, s.axis);
      if (std::abs(z) < 1e-12) {
        EXPECT_NEAR(r, s.orificeRadius, 1e-12);
        ++orifice;
      } else {
        EXPECT_NEAR(z, s.coneHeight + s.cylinderHeight, 1e-12);
        EXPECT_NEAR(r, s.topRadius, 1e-12);
        ++top;
      }
    }
  }
  const std::size_t n = *circleSegments(s.topRadius, {0.01, 5 * kPi / 180});
  EXPECT_EQ(orifice, 2 * n);
  EXPECT_EQ(top, 2 * n);
  // As a container the walls face the axis: particles inside.
  const TriMesh c = asContainer(*m);
  for (std::size_t t = 0; t < c.size(); ++t) {
    const Vec3d d = centroid(c, t) - s.orifice;
    EXPECT_LT(dot(areaNormal(c, t), d - dot(d, s.axis) * s.axis), 0.0);
  }
}

TEST(Hopper, ConeOnlyAndErrors) {
  HopperSpec s = hopperSpec();
  s.cylinderHeight = 0;
  s.openTop = false;
  auto m = tessellate(s);
  ASSERT_TRUE(m.isOk());
  EXPECT_EQ(surfacesOf(*m), (std::set<int>{0, 3}));
  EXPECT_EQ(boundaryEdges(*m).size(), 72u);  // only the orifice

  s.orificeRadius = 0.05;
  auto bad = tessellate(s);
  ASSERT_FALSE(bad.isOk());
  EXPECT_EQ(bad.status().message(), "orifice_radius must be < top_radius (0.05), got 0.05");
  s.orificeRadius = 0.01;
  s.cylinderHeight = -1;
  bad = tessellate(s);
  ASSERT_FALSE(bad.isOk());
  EXPECT_EQ(bad.status().message(), "cylinder_height must be >= 0 (and finite), got -1");
}

// --- mesh operations ------------------------------------------------------------------------------------------------------

TriMesh tetrahedron() {
  TriMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  m.surface = {0, 0, 0, 0};
  return m;
}

TEST(MeshOps, TetrahedronMeasures) {
  const TriMesh m = tetrahedron();
  EXPECT_TRUE(checkClosed(m).isOk());
  EXPECT_NEAR(signedVolume(m), 1.0 / 6, 1e-15);
  EXPECT_NEAR(area(m), 1.5 + std::sqrt(3.0) / 2, 1e-15);
  EXPECT_NEAR(signedVolume(flip(m)), -1.0 / 6, 1e-15);
  const Aabb b = bounds(m);
  EXPECT_EQ(b.hi.z, 1.0);
  EXPECT_EQ(b.lo.x, 0.0);
}

TEST(MeshOps, CheckClosedNamesTheFirstBadEdge) {
  TriMesh hole = tetrahedron();
  hole.triangles.pop_back();
  hole.surface.pop_back();
  const Status s = checkClosed(hole);
  ASSERT_FALSE(s.isOk());
  EXPECT_EQ(s.message(), "mesh is not closed: 3 of 6 edges are not shared by exactly two oppositely oriented triangles; first: edge (1, 2) of triangle 0 has no neighbour (a hole or an open boundary)");

  TriMesh twisted = tetrahedron();
  std::swap(twisted.triangles[3][1], twisted.triangles[3][2]);
  const Status t = checkClosed(twisted);
  ASSERT_FALSE(t.isOk());
  EXPECT_NE(t.message().find("3 of 6 edges"), std::string::npos) << t.message();
  EXPECT_NE(t.message().find("inconsistent orientation"), std::string::npos) << t.message();

  TriMesh outOfRange = tetrahedron();
  outOfRange.triangles[1][2] = 7;
  EXPECT_EQ(checkClosed(outOfRange).message(), "triangle 1 corner 2: vertex index 7 >= vertex count 4");
}

TEST(MeshOps, TransformScalesRotatesTranslates) {
  auto m = transform(tetrahedron(), 2.0, {0, 0, 1}, kPi / 2, {1, 0, 0});
  ASSERT_TRUE(m.isOk());
  EXPECT_NEAR(signedVolume(*m), 8.0 / 6, 1e-14);
  // (1, 0, 0) -> scaled (2, 0, 0) -> rotated (0, 2, 0) -> (1, 2, 0)
  EXPECT_NEAR(m->vertices[1].x, 1.0, 1e-15);
  EXPECT_NEAR(m->vertices[1].y, 2.0, 1e-15);
  EXPECT_FALSE(transform(tetrahedron(), -1, {0, 0, 1}, 0, {0, 0, 0}).isOk());
  EXPECT_FALSE(transform(tetrahedron(), 1, {0, 0, 0}, 1, {0, 0, 0}).isOk());
  EXPECT_TRUE(transform(tetrahedron(), 1, {0, 0, 0}, 0, {0, 0, 0}).isOk());
}

TEST(MeshOps, WeldMergesWithinToleranceOnly) {
  // Two triangles of a unit square as a soup, one shared corner nudged by 1e-9.
  TriMesh soup;
  soup.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 1e-9}, {1, 1, 0}, {0, 1, 0}};
  soup.triangles = {{0, 1, 2}, {3, 4, 5}};
  soup.surface = {0, 1};
  WeldStats exact;
  const TriMesh e = weldVertices(soup, 0, &exact);
  EXPECT_EQ(e.vertices.size(), 5u);
  EXPECT_EQ(exact.mergedVertices, 1u);
  WeldStats loose;
  const TriMesh l = weldVertices(soup, 1e-6, &loose);
  EXPECT_EQ(l.vertices.size(), 4u);
  EXPECT_EQ(l.triangles[1][0], 0u);
  EXPECT_EQ(l.surface, (std::vector<std::int32_t>{0, 1}));
  // A sliver whose corners merge is dropped.
  soup.vertices[5] = {1, 1, 1e-9};
  const TriMesh c = weldVertices(soup, 1e-6, &loose);
  EXPECT_EQ(loose.collapsedTriangles, 1u);
  EXPECT_EQ(c.size(), 1u);
  // -0 and +0 are the same coordinate.
  TriMesh zeros;
  zeros.vertices = {{0, 0, 0}, {-0.0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  zeros.triangles = {{0, 2, 3}, {1, 3, 2}};
  zeros.surface = {0, 0};
  EXPECT_EQ(weldVertices(zeros, 0).vertices.size(), 3u);
}

TEST(MeshOps, WeldsALargeSoupFast) {
  auto m = tessellate(BoxSpec{{0, 0, 0}, {1, 1, 1}, {}}, Tessellation{.maxEdge = 0.01});
  ASSERT_TRUE(m.isOk());
  TriMesh soup;
  for (const auto& t : m->triangles) {
    const auto base = static_cast<std::uint32_t>(soup.vertices.size());
    for (std::uint32_t v : t) soup.vertices.push_back(m->vertices[v] + Vec3d{1e-12, 0, 0});
    soup.triangles.push_back({base, base + 1, base + 2});
    soup.surface.push_back(0);
  }
  const TriMesh w = weldVertices(soup, 1e-9);
  EXPECT_EQ(w.vertices.size(), m->vertices.size());
  EXPECT_TRUE(checkClosed(w).isOk());
}

TEST(MeshOps, DegenerateTriangles) {
  TriMesh m = tetrahedron();
  m.vertices.push_back({2, 0, 0});  // collinear with 0 and 1
  m.triangles.push_back({0, 1, 4});
  m.triangles.push_back({2, 2, 3});
  m.surface.resize(m.triangles.size(), 0);
  EXPECT_EQ(degenerateTriangles(m), (std::vector<std::size_t>{4, 5}));
}

}  // namespace
}  // namespace pflow::frontend
