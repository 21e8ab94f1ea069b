// Walls driven by a force or a torque (motion.drive, compute/dem/WallDrive.h) against their closed-form trajectories:
// a plate spun up by a constant force or torque (x = F t^2 / 2M, theta = T t^2 / 2I), one that a limited drive brings
// to its target speed (a = F_lim / M until v = v0, then v0), a press that stops where the contacts carry its force
// limit (the Hertz overlap of a sphere squeezed between the press and the floor), and a checkpoint that resumes a
// driven wall where it was, bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "backend/store/DemSeries.h"
#include "compute/dem/Simulation.h"
#include "compute/sim/Domain.h"
#include "tests/support/CheckpointTest.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::MeshConfig;
using compute::MeshMotion;
using compute::RunConfig;
using compute::Simulation;

// A square plate of two triangles, side 2L, in the plane z = z0, facing down (particles below it).
MeshConfig plate(double z0, double L) {
  MeshConfig m;
  m.name = "plate";
  m.vertices = {{-L, -L, z0}, {L, -L, z0}, {L, L, z0}, {-L, L, z0}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  m.surface = {0, 0};
  return m;
}

// A scene with one sphere far from the plate (the engine needs particles) and the plate, driven by `drive`.
RunConfig freePlate(const MeshMotion& motion) {
  RunConfig c;
  c.materials = {material("bead", 1e7, 0.3, 2500, 0.5)};
  addParticle(c, {0, 0, -0.5}, 1e-3, 0);
  MeshConfig m = plate(0, 0.01);
  m.motion = motion;
  c.meshes = {m};
  c.surfaceNames = {"plate"};
  c.sim.gravity = {0, 0, 0};
  c.sim.dt = 1e-5;
  c.sim.duration = 1;
  return c;
}

std::unique_ptr<Simulation> make(const RunConfig& c) {
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}

// A vertex of the plate now (the geometry the engine moved).
Vec3d vertex(const Simulation& sim, int k) { return sim.geometry().vertices[std::size_t(k)]; }

TEST(WallDrive, ConstantForceAndTorqueSpinUpAsNewtonSays) {
  MeshMotion mo;
  MeshMotion::Drive d;
  d.mass = 0.2, d.force = {0, 0, 0.3};          // a = 1.5 m/s^2 along +z
  d.inertia = 2e-3, d.torque = 4e-3;            // alpha = 2 rad/s^2 about z through the origin
  mo.drive = d;
  mo.axis = {0, 0, 1};
  auto sim = make(freePlate(mo));
  ASSERT_TRUE(sim);
  ASSERT_TRUE(sim->runSteps(20000).isOk());  // 0.2 s
  const double t = sim->time(), a = 1.5, alpha = 2.0;
  const auto& w = sim->wallDrives().walls().at(0);
  EXPECT_NEAR(w.s, 0.5 * a * t * t, 1e-12);
  EXPECT_NEAR(w.v, a * t, 1e-12);
  EXPECT_NEAR(w.theta, 0.5 * alpha * t * t, 1e-12);
  EXPECT_NEAR(w.omega, alpha * t, 1e-12);
  // The mesh is where the drive says: the corner (L, -L, 0) turned by theta about z and lifted by s.
  const double th = 0.5 * alpha * t * t, L = 0.01;
  const Vec3d expected{L * std::cos(th) + L * std::sin(th), L * std::sin(th) - L * std::cos(th), 0.5 * a * t * t};
  double nearest = 1e300;
  for (const Vec3d& v : sim->geometry().vertices) nearest = std::min(nearest, norm(v - expected));
  EXPECT_LT(nearest, 1e-12);
}

// A drive that holds v0 = 0.05 m/s (and w0 = 3 rad/s) with at most 0.02 N (and 1e-3 N m) on a free plate: constant
// acceleration F_lim / M up to the target, then the target. The step that reaches it is the only one off the
// piecewise-parabolic closed form, by at most a dt^2.
TEST(WallDrive, LimitedDriveReachesItsTargetAtTheLimitsAcceleration) {
  MeshMotion mo;
  mo.velocity = {0.05, 0, 0};
  mo.angularSpeed = 3;
  mo.axis = {0, 0, 1};
  MeshMotion::Drive d;
  d.mass = 0.1, d.forceLimit = 0.02;     // a = 0.2 m/s^2: v0 after 0.25 s
  d.inertia = 1e-3, d.torqueLimit = 1e-3;  // alpha = 1 rad/s^2: w0 after 3 s
  mo.drive = d;
  auto sim = make(freePlate(mo));
  ASSERT_TRUE(sim);
  for (double until : {0.1, 0.5, 2.0, 4.0}) {
    ASSERT_TRUE(sim->runUntil(until).isOk());
    const double t = sim->time(), a = 0.2, v0 = 0.05, t1 = v0 / a, alpha = 1.0, w0 = 3.0, t2 = w0 / alpha;
    const double s = t < t1 ? 0.5 * a * t * t : v0 * t - 0.5 * v0 * t1;
    const double th = t < t2 ? 0.5 * alpha * t * t : w0 * t - 0.5 * w0 * t2;
    const auto& w = sim->wallDrives().walls().at(0);
    EXPECT_NEAR(w.s, s, 1e-9) << "t = " << t;
    EXPECT_NEAR(w.v, std::min(v0, a * t), 1e-9) << "t = " << t;
    EXPECT_NEAR(w.theta, th, 1e-8) << "t = " << t;
    EXPECT_NEAR(w.omega, std::min(w0, alpha * t), 1e-9) << "t = " << t;
    EXPECT_NEAR(std::fabs(w.driveForce), t < t1 ? 0.02 : 0.0, 1e-8) << "t = " << t;
  }
}

// A press (mass 0.1 g) comes down at 10 mm/s onto a soft sphere (r = 1 mm) on the floor with at most 0.05 N: it stops
// where both of the sphere's contacts carry 0.05 N, 2 R - 2 delta with delta = (3 F / (4 E* sqrt(R)))^{2/3} (Hertz;
// no gravity); the sphere's dashpot (e = 0.3) damps the press's bounce.
TEST(WallDrive, PressStopsWhereTheContactsCarryItsForceLimit) {
  const double R = 1e-3, E = 1e7, nu = 0.3, F = 0.05;
  RunConfig c;
  c.materials = {material("bead", E, nu, 2500, 0.3)};
  addParticle(c, {0, 0, R}, R, 0);
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
  c.planes[0].surface = 1;
  MeshConfig press = plate(2 * R + 1e-4, 4 * R);
  press.name = "press";
  press.motion.velocity = {0, 0, -0.01};
  MeshMotion::Drive d;
  d.mass = 1e-4, d.forceLimit = F;
  press.motion.drive = d;
  c.meshes = {press};
  c.surfaceNames = {"press", "floor"};
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1;
  auto sim = make(c);
  ASSERT_TRUE(sim);
  compute::Domain single;
  compute::SeriesConfig series;
  series.interval = 0.1;
  backend::DemSeriesRecorder recorder(*sim, single, series, c.surfaceNames);
  ASSERT_TRUE(sim->runUntil(0.4, [&](const Simulation& s) {
    recorder.sample(s, single);
    return Status::ok();
  }).isOk());
  const double effYoung = E / (1 - nu * nu);  // sphere on a wall of the same material: 1/E* = 2 (1 - nu^2) / E
  const double delta = std::pow(3 * F / (4 * 0.5 * effYoung * std::sqrt(R)), 2.0 / 3.0);
  const auto& w = sim->wallDrives().walls().at(0);
  const double gap = 2 * R + 1e-4 + w.s * w.direction.z;  // the press's height
  std::printf("press at %.9g m, closed form %.9g m (overlaps %.4g m each); drive %.5g N, contacts %.5g N, v %.3g m/s\n", gap,
              2 * R - 2 * delta, delta, w.driveForce, w.contactForce, w.v);
  EXPECT_NEAR((2 * R - gap) / (2 * delta), 1.0, 1e-3);
  EXPECT_NEAR(w.driveForce, F, 1e-9) << "the drive pushes at its limit";
  EXPECT_NEAR(w.contactForce, -F, 1e-3 * F) << "and the contacts carry it";
  EXPECT_NEAR(w.v, 0.0, 1e-5);
  // The series carry the press: its position, velocity and drive force, and its load (the force_z of its surface).
  const backend::ProbeSeries& rec = recorder.series();
  auto last = [&](const std::string& name) -> double {
    for (std::size_t k = 0; k < rec.names.size(); ++k)
      if (rec.names[k] == name) return rec.values[k].back();
    ADD_FAILURE() << "no series " << name;
    return NAN;
  };
  EXPECT_EQ(last("wall_position:press"), w.s);
  EXPECT_EQ(last("drive_force:press"), w.driveForce);
  EXPECT_NEAR(last("force_z:press"), F, 1e-3 * F) << "the sphere pushes the press up";
}

// Checkpointed after step 3000 of the press (coming down, in contact), resumed in a new run and taken to step 9000:
// the press and the sphere are where the uninterrupted run has them, bit for bit.
TEST(WallDrive, ResumedRunContinuesTheDrivenWall) {
  const double R = 1e-3;
  RunConfig c;
  c.materials = {material("bead", 1e7, 0.3, 2500, 0.3)};
  addParticle(c, {0, 0, R}, R, 0);
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
  c.planes[0].surface = 1;
  MeshConfig press = plate(2 * R + 1e-5, 4 * R);
  press.motion.velocity = {0, 0, -0.01};
  MeshMotion::Drive d;
  d.mass = 1e-4, d.forceLimit = 0.05;
  press.motion.drive = d;
  c.meshes = {press};
  c.surfaceNames = {"press", "floor"};
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1;
  c.sim.rebuildInterval = 500;  // a rebuild (where a state is taken) after step 3000, though nothing moves far
  auto straight = make(c), first = make(c), resumed = make(c);
  ASSERT_TRUE(straight && first && resumed);
  ASSERT_TRUE(straight->runSteps(9000).isOk());
  const auto state = checkpointAfter(*first, 3000);
  ASSERT_TRUE(state);
  ASSERT_EQ(state->wallDrive.size(), std::size_t(compute::WallDrives::kStateValues));
  ASSERT_TRUE(resumeTo(*resumed, *state, 9000));
  const auto& a = straight->wallDrives().walls().at(0);
  const auto& b = resumed->wallDrives().walls().at(0);
  EXPECT_EQ(a.s, b.s);
  EXPECT_EQ(a.v, b.v);
  EXPECT_EQ(vertex(*straight, 0).z, vertex(*resumed, 0).z);
  expectSameArrays(straight->snapshot(), resumed->snapshot(), {"position", "velocity"});
}

}  // namespace
}  // namespace pflow::test
