// Grid fields against hand-computed and analytic cases.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include "backend/fields/GridFields.h"

namespace pflow::backend {
namespace {

using compute::ParticleSnapshot;
using compute::ScalarType;
using compute::SnapshotArray;

SnapshotArray f64Array(const std::string& name, int components, const std::vector<double>& v) {
  SnapshotArray a{name, ScalarType::kF64, components, "", {}};
  a.data.resize(v.size() * sizeof(double));
  std::memcpy(a.data.data(), v.data(), a.data.size());
  return a;
}

struct P {
  Vec3d x, v;
  double r;
};

ParticleSnapshot snapshotOf(const std::vector<P>& ps) {
  ParticleSnapshot s;
  s.n = ps.size();
  std::vector<double> x, v, r;
  for (const auto& p : ps) {
    x.insert(x.end(), {p.x.x, p.x.y, p.x.z});
    v.insert(v.end(), {p.v.x, p.v.y, p.v.z});
    r.push_back(p.r);
  }
  s.arrays = {f64Array("position", 3, x), f64Array("velocity", 3, v), f64Array("radius", 1, r)};
  return s;
}

GridSpec spec(Vec3d origin, double h, std::uint32_t nx, std::uint32_t ny, std::uint32_t nz) {
  GridSpec g;
  g.origin = origin;
  g.cellSize = h;
  g.cells = {nx, ny, nz};
  return g;
}

double ballVolume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

TEST(GridFields, SingleParticleInsideOneCell) {
  const double r = 0.1, h = 1.0;
  auto f = computeGridFields(snapshotOf({{{0.5, 0.5, 0.5}, {1, 2, 3}, r}}), spec({0, 0, 0}, h, 2, 2, 2));
  ASSERT_TRUE(f) << f.status().toString();
  EXPECT_NEAR(f->solidFraction[0], ballVolume(r), 1e-15);
  for (std::size_t c = 1; c < 8; ++c) EXPECT_EQ(f->solidFraction[c], 0.0);
  EXPECT_DOUBLE_EQ(f->meanVelocity[0], 1);
  EXPECT_DOUBLE_EQ(f->meanVelocity[1], 2);
  EXPECT_DOUBLE_EQ(f->meanVelocity[2], 3);
  EXPECT_EQ(f->granularTemperature[0], 0.0);
}

// A sphere centred on a cell face puts exactly half its volume on each side; on a cell corner, 1/8 in each cell.
TEST(GridFields, SphereOnFaceAndCornerSplitsExactly) {
  const double r = 0.2;
  auto face = computeGridFields(snapshotOf({{{1.0, 0.5, 0.5}, {0, 0, 0}, r}}), spec({0, 0, 0}, 1.0, 2, 1, 1));
  ASSERT_TRUE(face);
  EXPECT_NEAR(face->solidFraction[0], 0.5 * ballVolume(r), 1e-15);
  EXPECT_NEAR(face->solidFraction[1], 0.5 * ballVolume(r), 1e-15);
  auto corner = computeGridFields(snapshotOf({{{1.0, 1.0, 1.0}, {0, 0, 0}, r}}), spec({0, 0, 0}, 1.0, 2, 2, 2));
  ASSERT_TRUE(corner);
  for (std::size_t c = 0; c < 8; ++c) EXPECT_NEAR(corner->solidFraction[c], ballVolume(r) / 8, 1e-15) << c;
}

// Simple cubic lattice of touching spheres (spacing d = 2r): phi = pi/6 in every cell that is a whole number of
// lattice periods wide, whatever the lattice's offset against the grid.
TEST(GridFields, UniformLatticeHasKnownSolidFraction) {
  const double r = 0.5e-3, d = 2 * r;
  for (double offset : {0.5, 0.0, 0.3}) {
    std::vector<P> ps;
    const int m = 12;
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j)
        for (int k = 0; k < m; ++k)
          ps.push_back({{(i + offset) * d, (j + offset) * d, (k + offset) * d}, {0, 0, 0}, r});
    // Cells of 2 periods; skip the boundary cells where the lattice ends.
    const GridSpec g = spec({0, 0, 0}, 2 * d, 6, 6, 6);
    auto f = computeGridFields(snapshotOf(ps), g);
    ASSERT_TRUE(f);
    for (std::size_t i = 1; i < 5; ++i)
      for (std::size_t j = 1; j < 5; ++j)
        for (std::size_t k = 1; k < 5; ++k)
          EXPECT_NEAR(f->solidFraction[g.index(i, j, k)], std::numbers::pi / 6, 1e-12) << offset;
    double total = 0;
    for (double phi : f->solidFraction) total += phi * g.cellSize * g.cellSize * g.cellSize;
    if (offset == 0.5) {
      EXPECT_NEAR(total, double(m * m * m) * ballVolume(r), 1e-12 * total);
    }
  }
}

// Two groups of equal spheres in one cell, velocities +u and -u (plus a drift): mean = drift, T = u^2 / 3.
TEST(GridFields, TwoGroupsGiveMeanAndTemperature) {
  const double r = 0.01, u = 2.0;
  const Vec3d drift{0.5, -0.25, 1.0};
  std::vector<P> ps;
  for (int i = 0; i < 5; ++i) {
    ps.push_back({{0.1 + 0.1 * i, 0.3, 0.3}, {drift.x + u, drift.y, drift.z}, r});
    ps.push_back({{0.1 + 0.1 * i, 0.6, 0.6}, {drift.x - u, drift.y, drift.z}, r});
  }
  auto f = computeGridFields(snapshotOf(ps), spec({0, 0, 0}, 1.0, 1, 1, 1));
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->meanVelocity[0], drift.x, 1e-14);
  EXPECT_NEAR(f->meanVelocity[1], drift.y, 1e-14);
  EXPECT_NEAR(f->meanVelocity[2], drift.z, 1e-14);
  EXPECT_NEAR(f->granularTemperature[0], u * u / 3, 1e-13);
}

// Mass weighting: a sphere of radius 2r weighs 8 x one of radius r (one density).
TEST(GridFields, MassWeightedByVolumeOrByMassArray) {
  std::vector<P> ps = {{{0.25, 0.5, 0.5}, {9, 0, 0}, 0.02}, {{0.75, 0.5, 0.5}, {0, 0, 0}, 0.04}};
  auto f = computeGridFields(snapshotOf(ps), spec({0, 0, 0}, 1.0, 1, 1, 1));
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->meanVelocity[0], 9.0 * 1 / 9, 1e-13);  // (1 * 9 + 8 * 0) / 9
  // <v> = 1, T = (1/3) (1 * 64 + 8 * 1) / 9 = 72 / 27
  EXPECT_NEAR(f->granularTemperature[0], 72.0 / 27.0, 1e-12);
  auto s = snapshotOf(ps);
  s.arrays.push_back(f64Array("mass", 1, {1.0, 2.0}));
  auto g = computeGridFields(s, spec({0, 0, 0}, 1.0, 1, 1, 1));
  ASSERT_TRUE(g);
  EXPECT_NEAR(g->meanVelocity[0], 3.0, 1e-13);
}

// A particle split over two cells contributes its velocity to both, weighted by the split.
TEST(GridFields, SplitParticleWeights) {
  const double r = 0.1;
  const double a = equalVolumeCubeSide(r);
  // Cube from 0.9 to 0.9 + a: a fraction (1 - 0.9) / a in cell 0.
  const double x = 0.9 + a / 2;
  std::vector<P> ps = {{{x, 0.5, 0.5}, {1, 0, 0}, r}, {{1.5, 0.5, 0.5}, {3, 0, 0}, r}};
  auto f = computeGridFields(snapshotOf(ps), spec({0, 0, 0}, 1.0, 2, 1, 1));
  ASSERT_TRUE(f);
  const double f0 = 0.1 / a;
  EXPECT_NEAR(f->solidFraction[0], f0 * ballVolume(r), 1e-15);
  EXPECT_NEAR(f->solidFraction[1], (2 - f0) * ballVolume(r), 1e-15);
  EXPECT_NEAR(f->meanVelocity[0], 1.0, 1e-14);
  const double mean1 = ((1 - f0) * 1 + 3) / (2 - f0);
  EXPECT_NEAR(f->meanVelocity[3], mean1, 1e-14);
  const double t1 = ((1 - f0) * (1 - mean1) * (1 - mean1) + (3 - mean1) * (3 - mean1)) / (3 * (2 - f0));
  EXPECT_NEAR(f->granularTemperature[1], t1, 1e-14);
}

TEST(GridFields, CoveringGridAndDefaultCellSize) {
  std::vector<P> ps = {{{0, 0, 0}, {0, 0, 0}, 0.01}, {{1, 0.5, 0.2}, {0, 0, 0}, 0.02}};
  auto f = computeGridFields(snapshotOf(ps), 0.0);
  ASSERT_TRUE(f) << f.status().toString();
  EXPECT_DOUBLE_EQ(f->spec.cellSize, 0.08);  // 4 x the largest radius
  EXPECT_DOUBLE_EQ(f->spec.origin.x, -0.01);
  EXPECT_EQ(f->spec.cells[0], 13u);  // ceil(1.03 / 0.08)
  double total = 0;
  for (double phi : f->solidFraction) total += phi * std::pow(f->spec.cellSize, 3);
  EXPECT_NEAR(total, ballVolume(0.01) + ballVolume(0.02), 1e-15);
  // A huge box coarsens the cells until the grid fits.
  ps.push_back({{1000, 1000, 1000}, {0, 0, 0}, 0.01});
  auto big = computeGridFields(snapshotOf(ps), 0.0);
  ASSERT_TRUE(big);
  EXPECT_LE(big->spec.cellCount(), kMaxGridCells);
  EXPECT_LE(std::size_t(big->spec.cells[1]) * big->spec.cells[2], kMaxGridSlabCells);
}

TEST(GridFields, BadInput) {
  auto s = snapshotOf({{{0, 0, 0}, {0, 0, 0}, 0.1}});
  EXPECT_FALSE(computeGridFields(s, spec({0, 0, 0}, 0.0, 1, 1, 1)));
  EXPECT_FALSE(computeGridFields(s, spec({0, 0, 0}, 1.0, 0, 1, 1)));
  s.arrays.pop_back();  // no radius
  auto f = computeGridFields(s, 1.0);
  ASSERT_FALSE(f);
  EXPECT_NE(f.status().message().find("radius"), std::string::npos);
  // Non-finite particles are skipped and counted.
  auto t = snapshotOf({{{NAN, 0, 0}, {0, 0, 0}, 0.1}, {{0.5, 0.5, 0.5}, {0, 0, 0}, 0.1}});
  auto g = computeGridFields(t, spec({0, 0, 0}, 1.0, 1, 1, 1));
  ASSERT_TRUE(g);
  EXPECT_EQ(g->skippedParticles, 1u);
}


// A fluid block (SPH snapshot: mass, density, pressure, kind; no radius) of spacing dp on a lattice whose period
// divides the cells: every cell inside is full (fluid fraction 1), the mean pressure is the mass-weighted mean of
// its particles' pressures (here a hydrostatic column), the boundary particles around it are left out, and there
// is no granular temperature.
TEST(GridFields, FluidFractionVelocityAndPressureOfAnSphSnapshot) {
  const double dp = 0.01, rho = 1000, g = 9.81, h = 2 * dp;
  const int n = 8;  // 8 x 8 x 8 fluid particles in [0, 0.08)^3, centres at (i + 1/2) dp
  std::vector<double> x, v, m, d, p;
  std::vector<std::int32_t> kind;
  for (int k = -1; k <= n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const bool wall = k < 0 || k == n;  // a layer of boundary particles below and above, far from rest
        x.insert(x.end(), {(i + 0.5) * dp, (j + 0.5) * dp, (k + 0.5) * dp});
        v.insert(v.end(), {wall ? 99.0 : 0.5, 0.0, wall ? 99.0 : -0.25});
        m.push_back(rho * dp * dp * dp);
        d.push_back(rho);
        p.push_back(wall ? 1e9 : rho * g * (n * dp - (k + 0.5) * dp));
        kind.push_back(wall ? 1 : 0);
      }
  ParticleSnapshot s;
  s.n = kind.size();
  SnapshotArray kinds{"kind", ScalarType::kI32, 1, "", {}};
  kinds.data.resize(kind.size() * 4);
  std::memcpy(kinds.data.data(), kind.data(), kinds.data.size());
  s.arrays = {f64Array("position", 3, x), f64Array("velocity", 3, v), f64Array("mass", 1, m), f64Array("density", 1, d),
              f64Array("pressure", 1, p), kinds};
  auto f = computeGridFields(s, spec({0, 0, 0}, h, 4, 4, 4));
  ASSERT_TRUE(f) << f.status().toString();
  EXPECT_TRUE(f->fluid);
  EXPECT_TRUE(f->granularTemperature.empty());
  ASSERT_EQ(f->meanPressure.size(), 64u);
  for (std::uint32_t c = 0; c < 64; ++c) {
    const std::uint32_t kz = c % 4;
    EXPECT_NEAR(f->solidFraction[c], 1.0, 1e-12) << c;
    EXPECT_NEAR(f->meanVelocity[3 * c], 0.5, 1e-12);
    EXPECT_NEAR(f->meanVelocity[3 * c + 2], -0.25, 1e-12);
    // The cell's two particle layers at (2 kz + 1/2) dp and (2 kz + 3/2) dp: their mean depth.
    EXPECT_NEAR(f->meanPressure[c], rho * g * (n * dp - (2.0 * kz + 1.0) * dp), 1e-9) << c;
  }
  // The grid the back-end chooses covers the fluid only (the boundary layers are not in the box).
  auto covering = computeGridFields(s, 0.0);
  ASSERT_TRUE(covering) << covering.status().toString();
  EXPECT_NEAR(covering->spec.origin.z, 0.5 * dp - fluidRadius(rho * dp * dp * dp, rho), 1e-12);
  EXPECT_NEAR(fluidRadius(rho * dp * dp * dp, rho), std::cbrt(3.0 / (4.0 * std::numbers::pi)) * dp, 1e-15);
}


// A planar (2D) fluid: mass per metre of depth rho dp^2, every particle at y = 0. Each is a dp x dp square in x-z
// across the grid's one layer in y: cells inside the block are full, the layer is centred on the plane.
TEST(GridFields, PlanarFluidFillsItsCells) {
  const double dp = 0.01, rho = 1000;
  std::vector<double> x, v, m, d;
  for (int k = 0; k < 8; ++k)
    for (int i = 0; i < 8; ++i) {
      x.insert(x.end(), {(i + 0.5) * dp, 0.0, (k + 0.5) * dp});
      v.insert(v.end(), {1.0, 0.0, 0.0});
      m.push_back(rho * dp * dp);
      d.push_back(rho);
    }
  ParticleSnapshot s;
  s.n = m.size();
  s.arrays = {f64Array("position", 3, x), f64Array("velocity", 3, v), f64Array("mass", 1, m), f64Array("density", 1, d)};
  auto f = computeGridFields(s, 2 * dp);
  ASSERT_TRUE(f) << f.status().toString();
  EXPECT_TRUE(f->fluid);
  EXPECT_EQ(f->spec.cells[1], 1u);
  EXPECT_NEAR(f->spec.origin.y, -dp, 1e-15);
  EXPECT_TRUE(f->meanPressure.empty());  // no pressure array
  // The box starts at the block's edge minus (radius - dp/2): cells away from the edges are full.
  double full = 0, total = 0;
  for (std::size_t c = 0; c < f->solidFraction.size(); ++c) {
    full = std::max(full, f->solidFraction[c]);
    total += f->solidFraction[c] * 4 * dp * dp;
  }
  EXPECT_NEAR(full, 1.0, 1e-12);
  EXPECT_NEAR(total, 64 * dp * dp, 1e-12);  // the block's area
}

}  // namespace
}  // namespace pflow::backend
