// The angle of repose's measurement (bench/ReposeHeap.h), on heaps built by hand: beads stacked on cones of known
// slope (with a flattened apex and a one-layer foot that the fit must leave out) give back the cone's angle, over all
// azimuths and in each quadrant. A poured pile's scene on the CPU: beads off the plate land on its tray.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>

#include "bench/ReposeHeap.h"

namespace {

using pflow::compute::ParticleSnapshot;
using pflow::compute::SnapshotArray;

SnapshotArray f64(const std::string& name, int components, const std::vector<double>& v) {
  SnapshotArray a;
  a.name = name, a.type = pflow::compute::ScalarType::kF64, a.components = components;
  a.data.resize(v.size() * sizeof(double));
  std::memcpy(a.data.data(), v.data(), a.data.size());
  return a;
}

// Beads of radius r filling a cone of the given slope and base radius R (columns of a jittered lattice, each topped
// by a bead touching the surface), its top flattened within `apex` of the axis and a foot one layer thick to 1.3 R.
ParticleSnapshot cone(double degrees, double R, double r, double apex) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jit(-0.2 * r, 0.2 * r);
  const double t = std::tan(degrees * std::numbers::pi / 180), H = R * t, s = 2 * r;
  std::vector<double> x, rad;
  for (double px = -1.3 * R; px <= 1.3 * R; px += s)
    for (double py = -1.3 * R; py <= 1.3 * R; py += s) {
      const double rho = std::hypot(px, py);
      if (rho > 1.3 * R) continue;
      double top = rho < R ? H - t * rho : 2 * r;  // the foot: one layer
      if (rho < apex) top = H - t * apex;          // the apex: flat
      for (double pz = r; pz + r <= std::max(top, 2 * r) - s + 1e-12; pz += s) {
        x.insert(x.end(), {px + jit(rng), py + jit(rng), pz});
        rad.push_back(r);
      }
      x.insert(x.end(), {px + jit(rng), py + jit(rng), std::max(top, 2 * r) - r});  // the column's top on the surface
      rad.push_back(r);
    }
  ParticleSnapshot snap;
  snap.n = rad.size();
  snap.arrays = {f64("position", 3, x), f64("radius", 1, rad)};
  return snap;
}

TEST(ReposeMeasure, ConesGiveBackTheirSlope) {
  for (double deg : {20.0, 25.0, 32.0}) {
    const double r = 0.0005, d = 2 * r;
    const ParticleSnapshot s = cone(deg, 0.05, r, 0.008);
    double from = 0, to = 0, radius = 0, height = 0;
    const double angle = pflow::bench::reposeAngle(pflow::bench::reposeProfile(s, 2 * d), d, &from, &to, &radius, &height);
    // The highest top in a ring two diameters wide is its inner edge's: the line is shifted, its slope is the cone's.
    EXPECT_NEAR(angle, deg, 0.5) << "heap radius " << radius << " m, fitted over " << from << "-" << to << " m";
    EXPECT_NEAR(radius, 0.05, 0.006);
    for (int q = 0; q < 4; ++q) EXPECT_NEAR(pflow::bench::reposeAngle(pflow::bench::reposeProfile(s, 2 * d, q), d), deg, 0.8) << q;
  }
}


// A run cut by its wall limit and taken up again from its checkpoint ends where the uncut run ends, to the last digit
// (pflow-repose --checkpoint --wall-limit: a poured pile takes two device sittings). A few hundred beads, a flat plate,
// a short lift, on the CPU.
TEST(ReposeCheckpoint, ACutRunGoesOnAsIfUncut) {
  pflow::bench::ReposeOptions o;
  o.particles = 300, o.roughness = 0, o.settle = 0.02, o.lift = 0.01, o.liftSpeed = 0.5, o.rest = 0.01;
  const auto kind = pflow::compute::ExecutorKind::kCpu;
  const pflow::bench::ReposeResult whole = pflow::bench::runRepose(o, kind);
  ASSERT_TRUE(whole.error.empty()) << whole.error;
  ASSERT_FALSE(whole.unfinished);
  o.checkpoint = ::testing::TempDir() + "repose_checkpoint_test.h5";
  std::remove(o.checkpoint.c_str());
  o.wallLimit = 1e-9;  // stops at the first rebuild
  const pflow::bench::ReposeResult cut = pflow::bench::runRepose(o, kind);
  ASSERT_TRUE(cut.error.empty()) << cut.error;
  ASSERT_TRUE(cut.unfinished);
  EXPECT_LT(cut.time, whole.time);
  o.wallLimit = 0;
  const pflow::bench::ReposeResult rest = pflow::bench::runRepose(o, kind);
  ASSERT_TRUE(rest.error.empty()) << rest.error;
  EXPECT_FALSE(rest.unfinished);
  EXPECT_EQ(rest.time, whole.time);
  EXPECT_EQ(rest.kineticEnergy, whole.kineticEnergy);
  EXPECT_EQ(rest.steps + cut.steps, whole.steps);
  // A checkpoint is refused by a run of other options.
  o.rolling = 0.2;
  const pflow::bench::ReposeResult other = pflow::bench::runRepose(o, kind);
  EXPECT_NE(other.error.find("another run's"), std::string::npos) << other.error;
  std::remove(o.checkpoint.c_str());
}

// The poured pile's scene runs, and the beads that spill off a small plate's edge come to rest on the tray 20 mm
// under it instead of falling on (which made a run rebuild its neighbour lists every other step by its end).
TEST(ReposePour, BeadsOffThePlateLandOnTheTray) {
  pflow::bench::ReposeOptions o;
  o.method = "pour";
  o.particles = 300, o.roughness = 0, o.plateHalfWidth = 0.006, o.settle = 0.02, o.pour = 0.25, o.rest = 0.05;
  const pflow::bench::ReposeResult r = pflow::bench::runRepose(o, pflow::compute::ExecutorKind::kCpu);
  ASSERT_TRUE(r.error.empty()) << r.error;
  std::printf("on the plate %zu of %zu, lowest centre %.4f m, %lld steps, %lld rebuilds\n", r.onPlate, r.particles, r.lowest,
              (long long)r.steps, (long long)r.rebuilds);
  EXPECT_LT(r.onPlate, r.particles) << "no bead reached the plate's edge: the tray is not tested";
  EXPECT_GT(r.lowest, -0.02) << "a bead fell through the tray";
  EXPECT_LT(r.lowest, -0.015) << "no bead reached the tray";
}

}  // namespace
