// Particle generators (frontend/generators): random numbers, size distributions, regions, lattice, random
// sequential addition, tiled fill, explicit lists and the particle CSV reader.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <numeric>
#include <set>

#include "frontend/SceneLoader.h"
#include "frontend/generators/Generators.h"
#include "frontend/geometry/Primitives.h"

namespace pflow::frontend {
namespace {

bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }
#define EXPECT_HAS(text, part) EXPECT_TRUE(contains(text, part)) << "want: " << (part) << "\ngot:\n" << (text)

double sphereVolume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

Region boxRegion(Vec3d lo, Vec3d hi) { return Region::box(lo, hi).value(); }

// Every pair through findOverlaps (cell grid), cross-checked against all pairs when small.
void expectNoOverlap(const Particles& p, std::span<const Vec3d> existingP = {}, std::span<const double> existingR = {}) {
  const auto overlaps = findOverlaps(p.position, p.radius, 1e-9, 5, existingP, existingR);
  for (const auto& o : overlaps) ADD_FAILURE() << "particles " << o.i << " and " << o.j << " overlap by " << o.depth;
  if (p.size() <= 2000) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      for (std::size_t j = i + 1; j < p.size(); ++j) {
        const double d = norm(p.position[i] - p.position[j]);
        ASSERT_GE(d - p.radius[i] - p.radius[j], -1e-9 * std::min(p.radius[i], p.radius[j])) << i << " " << j;
      }
    }
  }
}

void expectInside(const Particles& p, const Region& region, double tol = 1e-12) {
  for (std::size_t i = 0; i < p.size(); ++i) {
    ASSERT_TRUE(region.containsSphere(p.position[i], p.radius[i] * (1 - tol))) << "particle " << i;
  }
}

double solidVolume(const Particles& p) {
  double v = 0;
  for (double r : p.radius) v += sphereVolume(r);
  return v;
}

bool identical(const Particles& a, const Particles& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a.position[i].x != b.position[i].x || a.position[i].y != b.position[i].y || a.position[i].z != b.position[i].z || a.radius[i] != b.radius[i]) {
      return false;
    }
  }
  return true;
}

// A unit cube [0, 1]^3 with outward normals (12 triangles).
TriMesh cubeMesh(double lo = 0, double hi = 1) {
  TriMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.push_back({(i & 1) ? hi : lo, (i & 2) ? hi : lo, (i & 4) ? hi : lo});
  // Each face as a quad (a, b, c, d) counter-clockwise seen from outside.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({std::uint32_t(q[0]), std::uint32_t(q[1]), std::uint32_t(q[2])});
    m.triangles.push_back({std::uint32_t(q[0]), std::uint32_t(q[2]), std::uint32_t(q[3])});
  }
  m.surface.assign(m.triangles.size(), 0);
  return m;
}

// The octahedron |x| + |y| + |z| <= 1, outward normals.
TriMesh octahedronMesh() {
  TriMesh m;
  m.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int sx : {0, 1})
    for (int sy : {2, 3})
      for (int sz : {4, 5}) {
        std::array<std::uint32_t, 3> t{std::uint32_t(sx), std::uint32_t(sy), std::uint32_t(sz)};
        const Vec3d n = cross(m.vertices[t[1]] - m.vertices[t[0]], m.vertices[t[2]] - m.vertices[t[0]]);
        if (dot(n, m.vertices[t[0]]) < 0) std::swap(t[1], t[2]);
        m.triangles.push_back(t);
      }
  m.surface.assign(m.triangles.size(), 0);
  return m;
}

// A UV sphere of radius R with `slices` x `stacks` (2 slices (stacks - 1) triangles), outward normals.
TriMesh uvSphere(double radius, int slices, int stacks) {
  TriMesh m;
  m.vertices.push_back({0, 0, radius});  // north pole
  for (int k = 1; k < stacks; ++k) {
    const double theta = std::numbers::pi * k / stacks;
    for (int s = 0; s < slices; ++s) {
      const double phi = 2 * std::numbers::pi * s / slices;
      m.vertices.push_back({radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi), radius * std::cos(theta)});
    }
  }
  m.vertices.push_back({0, 0, -radius});  // south pole
  const auto ring = [&](int k, int s) { return std::uint32_t(1 + (k - 1) * slices + (s % slices)); };
  const std::uint32_t south = std::uint32_t(m.vertices.size() - 1);
  for (int s = 0; s < slices; ++s) m.triangles.push_back({0, ring(1, s), ring(1, s + 1)});
  for (int k = 1; k < stacks - 1; ++k) {
    for (int s = 0; s < slices; ++s) {
      m.triangles.push_back({ring(k, s), ring(k + 1, s), ring(k + 1, s + 1)});
      m.triangles.push_back({ring(k, s), ring(k + 1, s + 1), ring(k, s + 1)});
    }
  }
  for (int s = 0; s < slices; ++s) m.triangles.push_back({south, ring(stacks - 1, s + 1), ring(stacks - 1, s)});
  m.surface.assign(m.triangles.size(), 0);
  return m;
}

// ---- Random -------------------------------------------------------------------------------------------------------

TEST(Random, SameSeedSameNumbersAndKnownFirstValue) {
  Random a(42), b(42), c(43);
  std::mt19937_64 reference(42);
  const std::uint64_t first = reference();
  EXPECT_EQ(a.bits(), first);
  b.bits();
  for (int i = 0; i < 1000; ++i) {
    const double u = a.uniform();
    EXPECT_EQ(u, b.uniform());
    EXPECT_GE(u, 0.0);
    EXPECT_LT(u, 1.0);
  }
  EXPECT_NE(Random(42).uniform(), c.uniform());
  Random d(7);
  for (int i = 0; i < 1000; ++i) EXPECT_LT(d.below(7), 7u);
  EXPECT_EQ(streamSeed(1, 0), splitMix64(1 ^ splitMix64(0)));
}

// ---- SizeDistribution ---------------------------------------------------------------------------------------------

struct Moments {
  double mean = 0, sd = 0, min = 1e300, max = -1e300, meanCube = 0;
};
Moments sampleMoments(const SizeDistribution& d, int n, std::uint64_t seed = 3) {
  Random rng(seed);
  Moments m;
  double s = 0, s2 = 0, s3 = 0;
  for (int i = 0; i < n; ++i) {
    const double r = d.sample(rng);
    s += r;
    s2 += r * r;
    s3 += r * r * r;
    m.min = std::min(m.min, r);
    m.max = std::max(m.max, r);
  }
  m.mean = s / n;
  m.sd = std::sqrt(std::max(0.0, s2 / n - m.mean * m.mean));
  m.meanCube = s3 / n;
  return m;
}

// Sample mean within 5 standard errors of the distribution's mean; bounds respected; meanVolume consistent.
void expectStatistics(const SizeDistribution& d, double expectedMean, double expectedSd) {
  ASSERT_TRUE(d.validate().empty()) << d.validate().toString();
  const int n = 40000;
  const Moments m = sampleMoments(d, n);
  EXPECT_NEAR(m.mean, expectedMean, 5 * expectedSd / std::sqrt(double(n)) + 1e-15);
  EXPECT_NEAR(d.meanRadius(), expectedMean, 1e-6 * expectedMean + 5 * expectedSd / std::sqrt(double(n)));
  EXPECT_NEAR(m.sd, expectedSd, 0.03 * expectedSd + 1e-6 * expectedMean);  // + round-off of s2/n - mean^2
  EXPECT_GE(m.min, d.minRadius());
  EXPECT_LE(m.max, d.maxRadius());
  EXPECT_NEAR(d.meanVolume(), 4.0 / 3.0 * std::numbers::pi * m.meanCube, 0.02 * d.meanVolume());
}

TEST(SizeDistribution, SingleUniformNormalLogNormalStatistics) {
  const auto single = SizeDistribution::single(1e-3);
  expectStatistics(single, 1e-3, 0);
  EXPECT_EQ(single.meanVolume(), sphereVolume(1e-3));

  expectStatistics(SizeDistribution::uniform(1e-3, 2e-3), 1.5e-3, 1e-3 / std::sqrt(12.0));

  // Truncated normal: the truncation at +-1.5 sd symmetric around the mean keeps the mean and shrinks the sd
  // to sd * sqrt(1 - 2 a phi(a) / (2 Phi(a) - 1)), a = 1.5.
  const double a = 1.5, pdf = std::exp(-a * a / 2) / std::sqrt(2 * std::numbers::pi), mass = std::erf(a / std::numbers::sqrt2);
  const auto normal = SizeDistribution::normal(1e-3, 1e-4, 1e-3 - 1.5e-4, 1e-3 + 1.5e-4);
  expectStatistics(normal, 1e-3, 1e-4 * std::sqrt(1 - 2 * a * pdf / mass));
  // A barely truncated normal has its own mean and sd.
  expectStatistics(SizeDistribution::normal(1e-3, 1e-4, 1e-4, 1e-2), 1e-3, 1e-4);

  // Log-normal, median m and geometric sd g (wide bounds): mean m exp(s^2/2), sd mean sqrt(exp(s^2) - 1), s = ln g.
  const double med = 1e-3, g = 1.3, s = std::log(g);
  const double mean = med * std::exp(s * s / 2);
  const auto logNormal = SizeDistribution::logNormal(med, g, 1e-5, 1e-1);
  expectStatistics(logNormal, mean, mean * std::sqrt(std::exp(s * s) - 1));
  Random rng(9);
  std::vector<double> v(20001);
  for (double& r : v) r = logNormal.sample(rng);
  std::nth_element(v.begin(), v.begin() + 10000, v.end());
  EXPECT_NEAR(v[10000], med, 0.02 * med);
  // Truncated log-normal stays in its bounds.
  const auto tight = SizeDistribution::logNormal(med, 2.0, 0.8e-3, 1.5e-3);
  const Moments m = sampleMoments(tight, 5000);
  EXPECT_GE(m.min, 0.8e-3);
  EXPECT_LE(m.max, 1.5e-3);
  EXPECT_NEAR(m.mean, tight.meanRadius(), 0.01 * tight.meanRadius());
}

TEST(SizeDistribution, DiscreteByNumberAndByVolume) {
  const auto byNumber = SizeDistribution::discrete({1e-3, 2e-3}, {0.25, 0.75});
  ASSERT_TRUE(byNumber.validate().empty());
  const int n = 40000;
  Random rng(5);
  int small = 0;
  for (int i = 0; i < n; ++i) small += byNumber.sample(rng) == 1e-3;
  EXPECT_NEAR(small, 0.25 * n, 5 * std::sqrt(n * 0.25 * 0.75));
  EXPECT_EQ(byNumber.minRadius(), 1e-3);
  EXPECT_EQ(byNumber.maxRadius(), 2e-3);
  EXPECT_NEAR(byNumber.meanVolume(), 0.25 * sphereVolume(1e-3) + 0.75 * sphereVolume(2e-3), 1e-20);

  // Equal volume fractions of r and 2r: 8 small per large particle by number.
  const auto byVolume = SizeDistribution::discrete({1e-3, 2e-3}, {0.5, 0.5}, SizeDistribution::Basis::kVolume);
  ASSERT_TRUE(byVolume.validate().empty());
  EXPECT_NEAR(byVolume.numberFractions()[0], 8.0 / 9.0, 1e-12);
  double vSmall = 0, vAll = 0;
  for (int i = 0; i < n; ++i) {
    const double r = byVolume.sample(rng);
    vAll += sphereVolume(r);
    if (r == 1e-3) vSmall += sphereVolume(r);
  }
  EXPECT_NEAR(vSmall / vAll, 0.5, 0.02);
}

TEST(SizeDistribution, ValidateReportsEveryProblemWithItsBound) {
  const std::string single = SizeDistribution::single(-1).validate().toString();
  EXPECT_HAS(single, "size.radius: -1 must be > 0");
  const std::string nan = SizeDistribution::single(std::nan("")).validate().toString();
  EXPECT_HAS(nan, "size.radius: nan must be > 0");
  EXPECT_HAS(SizeDistribution::uniform(2e-3, 1e-3).validate("p.size").toString(), "p.size.min: 0.002 must be <= max 0.001");
  const auto normal = SizeDistribution::normal(-1, 0, 0, 1).validate();
  EXPECT_EQ(normal.size(), 3u) << normal.toString();
  EXPECT_HAS(normal.toString(), "size.mean: -1 must be > 0");
  EXPECT_HAS(normal.toString(), "size.std: 0 must be > 0");
  EXPECT_HAS(normal.toString(), "size.min: 0 must be > 0");
  EXPECT_HAS(SizeDistribution::normal(1e-3, 1e-5, 2e-3, 3e-3).validate().toString(), "keeps only 0 of the normal law");
  EXPECT_HAS(SizeDistribution::logNormal(1e-3, 1.0, 1e-4, 1e-2).validate().toString(), "size.geometric_std: 1 must be > 1");
  const std::string mix = SizeDistribution::discrete({1e-3, -2e-3}, {0.5, 0.4}).validate().toString();
  EXPECT_HAS(mix, "size.radii[1]: -0.002 must be > 0");
  EXPECT_HAS(mix, "size.fractions: sum to 0.9; fractions by number must sum to 1 within 1e-6");
  EXPECT_HAS(SizeDistribution::discrete({1e-3}, {0.5, 0.5}).validate().toString(), "size.fractions: has 2 entries; it must have one per radius (1)");
  EXPECT_TRUE(SizeDistribution::discrete({1e-3, 2e-3}, {0.5, 0.5 + 5e-7}).validate().empty());
}

// ---- Region -------------------------------------------------------------------------------------------------------

TEST(Region, BoxAndCylinder) {
  const Region box = boxRegion({0, 0, 0}, {1, 2, 3});
  EXPECT_DOUBLE_EQ(box.volume(), 6.0);
  EXPECT_TRUE(box.containsSphere({0.5, 1, 1.5}, 0.5));
  EXPECT_FALSE(box.containsSphere({0.5, 1, 1.5}, 0.51));
  EXPECT_FALSE(box.containsPoint({-0.01, 1, 1}));
  EXPECT_FALSE(Region::box({0, 0, 0}, {1, 0, 1}).isOk());

  // A cylinder along (1, 1, 0) from the origin.
  auto cyl = Region::cylinder({0, 0, 0}, {1, 1, 0}, 0.5, 2.0);
  ASSERT_TRUE(cyl.isOk());
  const Vec3d axis = (1 / std::sqrt(2.0)) * Vec3d{1, 1, 0};
  EXPECT_NEAR(cyl->volume(), std::numbers::pi * 0.25 * 2.0, 1e-12);
  EXPECT_TRUE(cyl->containsSphere(1.0 * axis, 0.5 * (1 - 1e-12)));  // on the axis up to round-off
  EXPECT_FALSE(cyl->containsSphere(1.0 * axis, 0.51));
  EXPECT_TRUE(cyl->containsSphere(1.0 * axis + Vec3d{0, 0, 0.39}, 0.1));
  EXPECT_FALSE(cyl->containsSphere(1.0 * axis + Vec3d{0, 0, 0.41}, 0.1));
  EXPECT_FALSE(cyl->containsSphere(0.05 * axis, 0.1));  // pokes out of the base
  const Bounds b = cyl->bounds();
  EXPECT_NEAR(b.min.z, -0.5, 1e-12);
  EXPECT_NEAR(b.max.x, 2 / std::sqrt(2.0) + 0.5 / std::sqrt(2.0), 1e-12);
  auto bad = Region::cylinder({0, 0, 0}, {0, 0, 0}, -1, 0);
  ASSERT_FALSE(bad.isOk());
  EXPECT_HAS(bad.status().message(), "cylinder.axis");
  EXPECT_HAS(bad.status().message(), "cylinder.radius: -1 must be > 0");
  EXPECT_HAS(bad.status().message(), "cylinder.height: 0 must be > 0");
  Random rng(1);
  for (int i = 0; i < 100; ++i) {
    const Vec3d p = box.samplePoint(rng);
    EXPECT_TRUE(box.containsPoint(p));
  }
}

TEST(Region, CubeMeshInsideAndDistance) {
  auto cube = Region::mesh(cubeMesh());
  ASSERT_TRUE(cube.isOk()) << cube.status().message();
  EXPECT_NEAR(cube->volume(), 1.0, 1e-12);
  Random rng(11);
  for (int i = 0; i < 20000; ++i) {
    const Vec3d p{rng.uniform(-0.5, 1.5), rng.uniform(-0.5, 1.5), rng.uniform(-0.5, 1.5)};
    const bool inside = p.x > 0 && p.x < 1 && p.y > 0 && p.y < 1 && p.z > 0 && p.z < 1;
    ASSERT_EQ(cube->containsPoint(p), inside) << p.x << " " << p.y << " " << p.z;
  }
  // Points exactly above shared edges and vertices of the x-y projection (the diagonals of top and bottom).
  EXPECT_TRUE(cube->containsPoint({0.5, 0.5, 0.5}));
  EXPECT_TRUE(cube->containsPoint({0.25, 0.25, 0.5}));
  EXPECT_TRUE(cube->containsPoint({0.75, 0.75, 0.1}));
  EXPECT_TRUE(cube->containsSphere({0.5, 0.5, 0.5}, 0.5));
  EXPECT_FALSE(cube->containsSphere({0.5, 0.5, 0.5}, 0.5001));
  EXPECT_TRUE(cube->containsSphere({0.2, 0.3, 0.8}, 0.19));
  EXPECT_FALSE(cube->containsSphere({0.2, 0.3, 0.8}, 0.21));

  // Flipped (a container's inward normals): negative volume, same inside.
  TriMesh flipped = cubeMesh();
  for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
  auto inward = Region::mesh(flipped);
  ASSERT_TRUE(inward.isOk());
  EXPECT_NEAR(inward->volume(), -1.0, 1e-12);
  EXPECT_TRUE(inward->containsSphere({0.5, 0.5, 0.5}, 0.4));
  EXPECT_FALSE(inward->containsPoint({1.5, 0.5, 0.5}));
}

TEST(Region, OctahedronMesh) {
  auto octa = Region::mesh(octahedronMesh());
  ASSERT_TRUE(octa.isOk()) << octa.status().message();
  EXPECT_NEAR(octa->volume(), 4.0 / 3.0, 1e-12);
  Random rng(12);
  for (int i = 0; i < 20000; ++i) {
    const Vec3d p{rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2)};
    const double l1 = std::fabs(p.x) + std::fabs(p.y) + std::fabs(p.z);
    if (std::fabs(l1 - 1) < 1e-12) continue;
    ASSERT_EQ(octa->containsPoint(p), l1 < 1) << p.x << " " << p.y << " " << p.z;
    const double r = 0.2;
    const double dist = (1 - l1) / std::sqrt(3.0);  // distance to the nearest face plane (inside, away from edges)
    if (std::fabs(dist - r) > 1e-9) {
      ASSERT_EQ(octa->containsSphere(p, r), l1 < 1 && dist >= r) << p.x << " " << p.y << " " << p.z;
    }
  }
  // On the projected vertex (0, 0) and edges of the x-y projection.
  EXPECT_TRUE(octa->containsPoint({0, 0, 0}));
  EXPECT_TRUE(octa->containsPoint({0, 0, 0.99}));
  EXPECT_FALSE(octa->containsPoint({0, 0, 1.01}));
  EXPECT_TRUE(octa->containsPoint({0.3, 0, 0.2}));
  EXPECT_TRUE(octa->containsPoint({0.3, 0.3, 0.2}));
}

TEST(Region, MeshErrors) {
  TriMesh open = cubeMesh();
  open.triangles.pop_back();
  auto r = Region::mesh(open);
  ASSERT_FALSE(r.isOk());
  EXPECT_HAS(r.status().message(), "belongs to one triangle only: the mesh is not closed");
  TriMesh inconsistent = cubeMesh();
  std::swap(inconsistent.triangles[0][1], inconsistent.triangles[0][2]);
  EXPECT_HAS(Region::mesh(inconsistent).status().message(), "orientation is inconsistent");
  TriMesh badIndex = cubeMesh();
  badIndex.triangles[3][0] = 99;
  EXPECT_HAS(Region::mesh(badIndex).status().message(), "mesh.triangles[3]: vertex index 99 is not below the vertex count 8");
}

TEST(Region, MillionPointsAgainstTenThousandTriangles) {
  const double R = 1.0;
  const int slices = 72, stacks = 71;
  const TriMesh sphere = uvSphere(R, slices, stacks);
  ASSERT_GE(sphere.size(), 10000u);
  auto region = Region::mesh(sphere);
  ASSERT_TRUE(region.isOk()) << region.status().message();
  EXPECT_GT(region->volume(), 0.99 * 4.0 / 3.0 * std::numbers::pi * std::pow(std::cos(std::numbers::pi / slices), 2));
  // The tessellated sphere lies between the inscribed radius (cos of half the largest angular step, squared, is a
  // safe bound) and R.
  const double inner = R * std::cos(std::numbers::pi / slices) * std::cos(std::numbers::pi / stacks);
  Random rng(13);
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t inside = 0, wrong = 0;
  for (int i = 0; i < 1000000; ++i) {
    const Vec3d p{rng.uniform(-1.1, 1.1), rng.uniform(-1.1, 1.1), rng.uniform(-1.1, 1.1)};
    const bool in = region->containsPoint(p);
    inside += in;
    const double d = norm(p);
    if ((d < inner && !in) || (d > R && in)) ++wrong;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(wrong, 0u);
  EXPECT_NEAR(static_cast<double>(inside) / 1e6 * std::pow(2.2, 3), region->volume(), 0.01);
  EXPECT_LT(seconds, 20.0) << "1e6 point-in-mesh tests took " << seconds << " s";
  std::printf("1e6 point-in-mesh tests against %zu triangles: %.3f s\n", sphere.size(), seconds);
  // Spheres against the mesh: those well inside are inside, those crossing the surface are not.
  for (int i = 0; i < 20000; ++i) {
    const Vec3d p{rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)};
    const double r = 0.05, d = norm(p);
    if (d + r < inner) {
      ASSERT_TRUE(region->containsSphere(p, r));
    }
    if (d + r > R) {
      ASSERT_FALSE(region->containsSphere(p, r));
    }
  }
}

// A long drum along a diagonal: its side triangles are thin and their bounding boxes cover most of the x-y
// grid; the columns hold each triangle only where its projection passes, and the inside test still agrees with
// the analytic cylinder (inside the inscribed polygon: in; beyond the radius or the ends: out).
TEST(Region, LongDiagonalDrumAgreesWithTheCylinder) {
  DrumSpec drum;
  drum.axis = Vec3d{1, 1, 0.3};
  drum.radius = 0.05;
  drum.length = 5.0;
  const TriMesh mesh = tessellate(drum).value();
  auto region = Region::mesh(mesh);
  ASSERT_TRUE(region.isOk()) << region.status().message();
  const Vec3d a = (1.0 / norm(drum.axis)) * drum.axis;
  const double inner = drum.radius * std::cos(std::numbers::pi / double(circleSegments(drum.radius, {}).value()));
  const Bounds b = region->bounds();
  Random rng(21);
  std::size_t inside = 0, checked = 0;
  for (int i = 0; i < 200000; ++i) {
    // Points near the axis (most of the bounds' volume is far from the drum).
    const double t = rng.uniform(-2.6, 2.6);
    const Vec3d p = t * a + Vec3d{rng.uniform(-0.06, 0.06), rng.uniform(-0.06, 0.06), rng.uniform(-0.06, 0.06)};
    const double along = dot(p, a), d = norm(p - along * a);
    const bool in = region->containsPoint(p);
    inside += in;
    if (d < inner - 1e-12 && std::fabs(along) < 0.5 * drum.length - 1e-12) {
      ++checked;
      ASSERT_TRUE(in) << "at " << p.x << ", " << p.y << ", " << p.z;
    }
    if (d > drum.radius || std::fabs(along) > 0.5 * drum.length) ASSERT_FALSE(in) << "at " << p.x << ", " << p.y << ", " << p.z;
  }
  EXPECT_GT(checked, 10000u);
  EXPECT_GT(b.size().x, 3.0);
}

// ---- lattice ------------------------------------------------------------------------------------------------------

// The scene loader's lattice is this generator, seeded per set from simulation.seed (docs/scene-format.md).
TEST(Lattice, SameAsTheSceneLoaderBitForBit) {
  const std::string yaml =
      "materials:\n  - {name: glass, youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5}\n"
      "particles:\n"
      "  - list: [{position: [1, 1, 1], radius: 0.0005}]\n"
      "  - {method: lattice, region: {box: {min: [0, 0, 0], max: [0.01, 0.005, 0.003]}}, size: 0.0005,\n"
      "     lattice: {spacing: 0.00105, jitter: 0.02}, count: 50}\n"
      "simulation:\n  duration: 0.1\n  seed: 77\n";
  const auto scene = loadSceneFromString(yaml);
  ASSERT_TRUE(scene.isOk()) << scene.status().message();
  LatticeOptions options;
  options.spacing = 0.00105;
  options.jitter = 0.02;
  options.count = 50;
  auto p = generateLattice(boxRegion({0, 0, 0}, {0.01, 0.005, 0.003}), SizeDistribution::single(0.0005), options, streamSeed(77, 1));
  ASSERT_TRUE(p.isOk()) << p.status().message();
  const auto& loaded = scene->config.particles;
  ASSERT_EQ(p->size() + 1, loaded.size());
  for (std::size_t i = 0; i < p->size(); ++i) {
    EXPECT_EQ(p->position[i].x, loaded.position[i + 1].x);
    EXPECT_EQ(p->position[i].y, loaded.position[i + 1].y);
    EXPECT_EQ(p->position[i].z, loaded.position[i + 1].z);
    EXPECT_EQ(p->radius[i], loaded.radius[i + 1]);
  }
}

TEST(Lattice, JitterBoundCountAndFillOrder) {
  const double r = 1e-3, spacing = 2.2e-3;
  LatticeOptions options;
  options.spacing = spacing;
  options.jitter = maxLatticeJitter(options.packing, spacing, r);  // the largest allowed: 0.1
  EXPECT_NEAR(options.jitter, 0.1, 1e-12);
  const Region box = boxRegion({0, 0, 0}, {0.02, 0.02, 0.02});
  auto p = generateLattice(box, SizeDistribution::single(r), options, 5);
  ASSERT_TRUE(p.isOk()) << p.status().message();
  EXPECT_EQ(p->size(), 9u * 9u * 9u);
  expectNoOverlap(*p);
  expectInside(*p, box);
  bool moved = false;
  for (std::size_t i = 0; i < p->size(); ++i) {
    const Vec3d x = p->position[i];
    const Vec3d site{r + static_cast<double>(i % 9) * spacing, r + static_cast<double>(i / 9 % 9) * spacing, r + static_cast<double>(i / 81) * spacing};
    const Vec3d d = x - site;
    ASSERT_LE(std::max({std::fabs(d.x), std::fabs(d.y), std::fabs(d.z)}), options.jitter * r * (1 + 1e-9)) << i;
    moved = moved || norm(d) > 0;
  }
  EXPECT_TRUE(moved);

  options.count = 100;
  auto capped = generateLattice(box, SizeDistribution::single(r), options, 5);
  ASSERT_TRUE(capped.isOk());
  ASSERT_EQ(capped->size(), 100u);
  EXPECT_NEAR(capped->position[80].z, r, 0.11 * r);  // 81 per layer: the bottom layer first
  EXPECT_NEAR(capped->position[81].z, r + spacing, 0.11 * r);

  options.count = 1000;
  auto tooMany = generateLattice(box, SizeDistribution::single(r), options, 5);
  ASSERT_FALSE(tooMany.isOk());
  EXPECT_HAS(tooMany.status().message(), "lattice: count 1000 is more than the 729 lattice particles that fit");

  options.count.reset();
  options.jitter = 0.11;
  auto tooMuch = generateLattice(box, SizeDistribution::single(r), options, 5);
  ASSERT_FALSE(tooMuch.isOk());
  EXPECT_HAS(tooMuch.status().message(), "lattice.jitter: 0.11 lets neighbouring particles overlap");
  options.jitter = 0;
  options.spacing = 1.9e-3;
  EXPECT_HAS(generateLattice(box, SizeDistribution::single(r), options, 5).status().message(), "lattice.spacing: 0.0019 must be >= the largest diameter 0.002");
}

// A thin diagonal cylinder in large bounds: the sites visited are bounded, and the error says where it stopped.
TEST(Lattice, StopsAtTheSiteLimitWithAClearError) {
  const Region cyl = Region::cylinder({0, 0, 0}, {1, 1, 0}, 0.01, 2.0).value();
  LatticeOptions options;
  options.count = 500;
  options.maxSites = 10000;
  auto p = generateLattice(cyl, SizeDistribution::single(1e-3), options, 5);
  ASSERT_FALSE(p.isOk());
  EXPECT_EQ(p.status().code(), StatusCode::kResourceExhausted);
  EXPECT_HAS(p.status().message(), "lattice: visited 10000 sites of the region's bounds");
  options.maxSites = std::numeric_limits<std::size_t>::max();
  auto all = generateLattice(cyl, SizeDistribution::single(1e-3), options, 5);
  ASSERT_TRUE(all.isOk()) << all.status().message();
  EXPECT_EQ(all->size(), 500u);
}

TEST(Lattice, HexagonalClosePackedAndPolydisperseInACylinder) {
  const double r = 1e-3;
  LatticeOptions options;
  options.packing = LatticeOptions::Packing::kHexagonalClosePacked;
  options.spacing = 2.02e-3;
  options.jitter = maxLatticeJitter(options.packing, options.spacing, r);
  const Region box = boxRegion({0, 0, 0}, {0.03, 0.03, 0.03});
  auto p = generateLattice(box, SizeDistribution::single(r), options, 8);
  ASSERT_TRUE(p.isOk()) << p.status().message();
  expectNoOverlap(*p);
  expectInside(*p, box);
  // HCP at nearest-neighbour distance s fills pi / (3 sqrt 2) (r / (s / 2))^3 of space, less at the walls.
  const double phi = solidVolume(*p) / box.volume();
  EXPECT_GT(phi, 0.55);
  EXPECT_LT(phi, 0.74);

  auto cyl = Region::cylinder({0, 0, 0}, {0, 0, 1}, 0.01, 0.02).value();
  LatticeOptions sc;
  sc.jitter = 0.02;
  auto poly = generateLattice(cyl, SizeDistribution::uniform(0.5e-3, 1e-3), sc, 9);
  ASSERT_TRUE(poly.isOk()) << poly.status().message();
  EXPECT_GT(poly->size(), 500u);
  expectNoOverlap(*poly);
  expectInside(*poly, cyl);
}

// ---- random sequential addition -----------------------------------------------------------------------------------

TEST(RandomFill, ExactCountNoOverlapDeterministic) {
  const Region box = boxRegion({0, 0, 0}, {0.02, 0.02, 0.02});
  RandomOptions options;
  options.count = 1500;
  const auto size = SizeDistribution::uniform(0.4e-3, 0.8e-3);
  auto a = generateRandom(box, size, options, 21);
  auto b = generateRandom(box, size, options, 21);
  auto c = generateRandom(box, size, options, 22);
  ASSERT_TRUE(a.isOk() && b.isOk() && c.isOk()) << a.status().message();
  EXPECT_EQ(a->size(), 1500u);
  expectNoOverlap(*a);
  expectInside(*a, box);
  EXPECT_TRUE(identical(*a, *b));
  EXPECT_FALSE(identical(*a, *c));
  // Largest first.
  EXPECT_TRUE(std::is_sorted(a->radius.begin(), a->radius.end(), std::greater<>()));
}

TEST(RandomFill, ReachesThirtyPercentForEqualSpheresInABox) {
  const Region box = boxRegion({0, 0, 0}, {0.04, 0.04, 0.04});
  RandomOptions options;
  options.solidFraction = 0.30;
  auto p = generateRandom(box, SizeDistribution::single(1e-3), options, 3);
  ASSERT_TRUE(p.isOk()) << p.status().message();
  const double phi = solidVolume(*p) / box.volume();
  EXPECT_GE(phi, 0.30);
  EXPECT_LT(phi, 0.30 + sphereVolume(1e-3) / box.volume() * 1.0001);  // stops at the first radius reaching the target
  expectNoOverlap(*p);
  expectInside(*p, box);
}

TEST(RandomFill, AvoidsExistingSpheresAndTheRejectRule) {
  const Region box = boxRegion({0, 0, 0}, {0.02, 0.02, 0.02});
  // Earlier particles: a lattice in the lower half.
  LatticeOptions lattice;
  auto earlier = generateLattice(boxRegion({0, 0, 0}, {0.02, 0.02, 0.01}), SizeDistribution::single(1e-3), lattice, 1);
  ASSERT_TRUE(earlier.isOk());
  Avoid avoid;
  avoid.position = earlier->position;
  avoid.radius = earlier->radius;
  // A wall: the plane x + y = 0.03 (particles must stay on the low side, clear of it).
  avoid.reject = [](const Vec3d& c, double r) { return (c.x + c.y - 0.03) / std::sqrt(2.0) > -r; };
  RandomOptions options;
  options.count = 300;
  auto p = generateRandom(box, SizeDistribution::uniform(0.3e-3, 0.6e-3), options, 4, avoid);
  ASSERT_TRUE(p.isOk()) << p.status().message();
  EXPECT_EQ(p->size(), 300u);
  expectNoOverlap(*p, earlier->position, earlier->radius);
  for (std::size_t i = 0; i < p->size(); ++i) ASSERT_FALSE(avoid.reject(p->position[i], p->radius[i]));
}

TEST(RandomFill, CylinderAndMeshRegions) {
  auto cyl = Region::cylinder({0, 0, 0}, {1, 0, 1}, 0.01, 0.03).value();
  RandomOptions options;
  options.solidFraction = 0.25;
  auto p = generateRandom(cyl, SizeDistribution::single(1e-3), options, 6);
  ASSERT_TRUE(p.isOk()) << p.status().message();
  EXPECT_GE(solidVolume(*p) / cyl.volume(), 0.25);
  expectNoOverlap(*p);
  expectInside(*p, cyl);

  TriMesh octa = octahedronMesh();
  for (auto& v : octa.vertices) v = 0.02 * v;
  auto mesh = Region::mesh(octa).value();
  auto q = generateRandom(mesh, SizeDistribution::normal(1e-3, 2e-4, 0.6e-3, 1.4e-3), options, 7);
  ASSERT_TRUE(q.isOk()) << q.status().message();
  EXPECT_GE(solidVolume(*q) / mesh.volume(), 0.25);
  expectNoOverlap(*q);
  expectInside(*q, mesh);
}

TEST(RandomFill, CannotFitSaysHowFarItGot) {
  const Region box = boxRegion({0, 0, 0}, {0.01, 0.01, 0.01});
  RandomOptions options;
  options.solidFraction = 0.5;
  options.maxAttemptsPerParticle = 2000;
  auto p = generateRandom(box, SizeDistribution::single(0.5e-3), options, 1);
  ASSERT_FALSE(p.isOk());
  EXPECT_EQ(p.status().code(), StatusCode::kResourceExhausted);
  const std::string& m = p.status().message();
  EXPECT_HAS(m, "random: the region cannot hold the request: particle ");
  EXPECT_HAS(m, " attempts; placed ");
  EXPECT_HAS(m, " attempts in all; solid fraction reached 0.");
  EXPECT_HAS(m, " of the requested 0.5");
  EXPECT_HAS(m, "jams near 0.38");

  options.solidFraction.reset();
  options.count = 1;
  auto huge = generateRandom(box, SizeDistribution::single(0.006), options, 1);
  ASSERT_FALSE(huge.isOk());
  EXPECT_HAS(huge.status().message(), "cannot hold one sphere of radius 0.006");

  RandomOptions both;
  both.count = 3;
  both.solidFraction = 0.8;
  auto bad = generateRandom(box, SizeDistribution::single(-1), both, 1);
  ASSERT_FALSE(bad.isOk());
  EXPECT_HAS(bad.status().message(), "random.size.radius: -1 must be > 0");
  EXPECT_HAS(bad.status().message(), "random: give exactly one of 'count' and 'solid_fraction'");
  EXPECT_HAS(bad.status().message(), "random.solid_fraction: 0.8 must be in (0, 0.7405)");
}

// ---- tiled --------------------------------------------------------------------------------------------------------

TEST(Tiled, CopiesDoNotOverlapAcrossTileBorders) {
  // Edge 10 diameters, a box of 3.5 x 2.5 x 2.2 tiles.
  const double r = 1e-3;
  const Region box = boxRegion({0.001, -0.002, 0.0}, {0.001 + 0.07, -0.002 + 0.05, 0.044});
  TiledOptions options;
  options.solidFraction = 0.32;
  auto a = generateTiled(box, SizeDistribution::single(r), options, 31);
  ASSERT_TRUE(a.isOk()) << a.status().message();
  expectNoOverlap(*a);
  expectInside(*a, box);
  const double phi = solidVolume(*a) / box.volume();
  EXPECT_GT(phi, 0.28);  // a little below the tile's 0.32: spheres cut by the walls are dropped
  EXPECT_LE(phi, 0.33);
  // Fill order: lowest z first.
  for (std::size_t i = 1; i < a->size(); ++i) ASSERT_LE(a->position[i - 1].z, a->position[i].z);
  auto b = generateTiled(box, SizeDistribution::single(r), options, 31);
  ASSERT_TRUE(b.isOk());
  EXPECT_TRUE(identical(*a, *b));

  // count: the first N in fill order.
  TiledOptions counted = options;
  counted.count = 1000;
  auto c = generateTiled(box, SizeDistribution::single(r), counted, 31);
  ASSERT_TRUE(c.isOk()) << c.status().message();
  ASSERT_EQ(c->size(), 1000u);
  for (std::size_t i = 0; i < c->size(); ++i) ASSERT_EQ(c->position[i].z, a->position[i].z);
  counted.count = a->size() + 1;
  auto tooMany = generateTiled(box, SizeDistribution::single(r), counted, 31);
  ASSERT_FALSE(tooMany.isOk());
  EXPECT_HAS(tooMany.status().message(), "is more than the " + std::to_string(a->size()) + " particles the region holds");
}

TEST(Tiled, PolydisperseSmallTileAndExisting) {
  const Region box = boxRegion({0, 0, 0}, {0.03, 0.03, 0.03});
  const Particles existing{{{0.015, 0.015, 0.015}}, {0.005}};
  Avoid avoid;
  avoid.position = existing.position;
  avoid.radius = existing.radius;
  TiledOptions options;
  options.tileEdge = 0.008;  // 4 largest diameters: many copies, many borders
  options.solidFraction = 0.3;
  auto p = generateTiled(box, SizeDistribution::discrete({0.5e-3, 1e-3}, {0.5, 0.5}, SizeDistribution::Basis::kVolume), options, 2, avoid);
  ASSERT_TRUE(p.isOk()) << p.status().message();
  expectNoOverlap(*p, existing.position, existing.radius);
  expectInside(*p, box);
  TiledOptions small;
  small.tileEdge = 0.003;
  EXPECT_HAS(generateTiled(box, SizeDistribution::single(1e-3), small, 1).status().message(),
             "tiled.tile_edge: 0.003 must be >= 2 x the largest diameter 0.002");
}

// ---- list and CSV -------------------------------------------------------------------------------------------------

TEST(List, ChecksOverlapsRegionAndExisting) {
  const Particles ok{{{0, 0, 0}, {0.002, 0, 0}}, {1e-3, 1e-3}};  // touching is fine
  EXPECT_TRUE(generateList(ok).isOk());
  const Particles overlapping{{{0, 0, 0}, {0.0019, 0, 0}, {0.1, 0, 0}}, {1e-3, 1e-3, -1}};
  auto bad = generateList(overlapping);
  ASSERT_FALSE(bad.isOk());
  EXPECT_HAS(bad.status().message(), "list[2].radius: -1 must be > 0");
  const Particles two{{{0, 0, 0}, {0.0019, 0, 0}}, {1e-3, 1e-3}};
  EXPECT_HAS(generateList(two).status().message(), "list[0]: overlaps list[1] by 0.0001");
  const std::vector<Vec3d> ep{{0.004, 0, 0}};
  const std::vector<double> er{0.0025};
  EXPECT_HAS(generateList(ok, Avoid{ep, er, {}}).status().message(), "list[1]: overlaps existing sphere 0");
  const Region box = boxRegion({-0.0005, -0.001, -0.001}, {0.01, 0.01, 0.01});
  EXPECT_HAS(generateList(ok, {}, &box).status().message(), "list[0]: the sphere at [0, 0, 0] with radius 0.001 is not inside the region");
}

TEST(ParticleCsv, HappyPathAnyOrderCommentsVelocities) {
  const std::string text =
      "# particles for the drum\n"
      "radius, z, y, x, wx, wy, wz, vx,vy,vz   # header\n"
      "\n"
      "0.001, 3, 2, 1, 0, 0, 10, -1, 0, 0\n"
      "  2e-3 ,6,5,4, 1,2,3, 0.5,0.25,0.125 # second\r\n";
  const auto p = parseParticleCsv(text, "drum.csv");
  ASSERT_TRUE(p.isOk()) << p.status().message();
  ASSERT_EQ(p->size(), 2u);
  EXPECT_EQ(p->position[0].x, 1);
  EXPECT_EQ(p->position[0].z, 3);
  EXPECT_EQ(p->radius[1], 2e-3);
  ASSERT_TRUE(p->velocity.has_value());
  ASSERT_TRUE(p->angularVelocity.has_value());
  EXPECT_EQ((*p->velocity)[1].z, 0.125);
  EXPECT_EQ((*p->angularVelocity)[0].z, 10);

  const auto plain = parseParticleCsv("x,y,z,radius\n0,0,0,1\n");
  ASSERT_TRUE(plain.isOk());
  EXPECT_FALSE(plain->velocity.has_value());
  EXPECT_FALSE(plain->angularVelocity.has_value());

  const std::string path = ::testing::TempDir() + "/pflow_particles.csv";
  std::ofstream(path) << text;
  const auto file = readParticleCsv(path);
  ASSERT_TRUE(file.isOk()) << file.status().message();
  EXPECT_EQ(file->size(), 2u);
  std::remove(path.c_str());
}

TEST(ParticleCsv, EveryErrorWithItsLine) {
  const auto header = parseParticleCsv("x,y,radius,vx,vy,color,x\n", "a.csv");
  ASSERT_FALSE(header.isOk());
  const std::string& h = header.status().message();
  EXPECT_HAS(h, "line 1, column 18: a.csv: unknown column 'color'");
  EXPECT_HAS(h, "line 1, column 24: a.csv: column 'x' appears twice");
  EXPECT_HAS(h, "a.csv: missing column 'z' (x, y, z and radius are required)");
  EXPECT_HAS(h, "a.csv: columns vx, vy, vz must be given together");

  const auto rows = parseParticleCsv("# comment\nx,y,z,radius\n1,2,3,0.1\n1,2,abc,0.1\n1,2,3\n1,2,3,-0.5\n1,2,3,4,5\n1,2,,1\n", "b.csv");
  ASSERT_FALSE(rows.isOk());
  const std::string& m = rows.status().message();
  EXPECT_HAS(m, "line 4, column 5: b.csv: column 'z': 'abc' is not a finite number");
  EXPECT_HAS(m, "line 5, column 1: b.csv: 3 values; the header has 4 columns");
  EXPECT_HAS(m, "line 6, column 7: b.csv: column 'radius': -0.5 must be > 0");
  EXPECT_HAS(m, "line 7, column 1: b.csv: 5 values; the header has 4 columns");
  EXPECT_HAS(m, "line 8, column 5: b.csv: column 'z': '' is not a finite number");

  EXPECT_HAS(parseParticleCsv("# nothing\n\n", "c.csv").status().message(), "c.csv: no header line");
  const auto missing = readParticleCsv("/nonexistent/particles.csv");
  ASSERT_FALSE(missing.isOk());
  EXPECT_EQ(missing.status().code(), StatusCode::kIo);
  EXPECT_HAS(missing.status().message(), "cannot open particle CSV '/nonexistent/particles.csv'");
}

TEST(FindOverlaps, AgreesWithAllPairs) {
  Random rng(4);
  std::vector<Vec3d> p(500);
  std::vector<double> r(500);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p[i] = {rng.uniform(0, 0.1), rng.uniform(0, 0.1), rng.uniform(0, 0.1)};
    r[i] = rng.uniform(0.001, 0.004);
  }
  std::size_t brute = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) brute += norm(p[i] - p[j]) < r[i] + r[j] - 1e-9 * std::min(r[i], r[j]);
  EXPECT_GT(brute, 0u);
  EXPECT_EQ(findOverlaps(p, r, 1e-9, 1000000).size(), brute);
}

}  // namespace
}  // namespace pflow::frontend
