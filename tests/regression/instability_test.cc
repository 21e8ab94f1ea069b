// Run-time instability detectors (docs/physics.md, "Instability detectors"): each failure is provoked on
// purpose and must be caught with an error that starts with its cause keyword and names the particle(s),
// the step, the time and a suggested dt; legitimate scenes must not trip them; reduce_dt recovers a run
// that `stop` ends.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "compute/dem/Simulation.h"
#include "compute/dem/TimeStep.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

bool startsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

// Every detector's message: the cause keyword first, then the particle, the suggested dt, the step and time.
void expectReport(const Status& s, const std::string& keyword, const std::string& particle) {
  ASSERT_FALSE(s.isOk());
  EXPECT_EQ(s.code(), StatusCode::kNumerical) << s.toString();
  std::printf("reported: %s\n", s.message().c_str());
  EXPECT_TRUE(startsWith(s.message(), keyword)) << s.message();
  EXPECT_NE(s.message().find(particle), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("suggested dt "), std::string::npos) << s.message();
  EXPECT_NE(s.message().find(" at step "), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("(t = "), std::string::npos) << s.message();
}

Status runToEnd(const RunConfig& c, std::unique_ptr<Simulation>* keep = nullptr) {
  auto sim = Simulation::create(c);
  if (!sim.isOk()) return sim.status();
  Status s = sim.value()->runUntil(c.sim.duration);
  if (keep) *keep = std::move(sim).value();
  return s;
}


// A time step too large for the contacts (1.5 Rayleigh times; 1.2 is still stable here): the mechanical
// energy grows, and the energy detector stops the run before any value becomes non-finite and before any
// overlap reaches the limit. (From 2 Rayleigh times on, this block blows up within a few steps, between
// two energy checks: tunnelling or excessive overlap is reported then, also before anything is non-finite.)
TEST(Instability, EnergyGrowthCaughtBeforeNonFinite) {
  const RunConfig c = compressedBlock(1.5);
  const Status s = runToEnd(c);
  expectReport(s, "energy growth:", "the fastest is particle ");
  EXPECT_NE(s.message().find("time step too large"), std::string::npos) << s.message();
}

// A fast particle crosses a floor plane within one step.
TEST(Instability, TunnellingThroughPlane) {
  RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, 0.9)};
  const double r = 0.01;
  addParticle(c, {0, 0, 2 * r}, r, 0, {0, 0, -50});
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
  c.sim.gravity = {0, 0, 0};
  c.sim.dt = 2 * r / 50 * 1.5;  // 3 radii per step: from 2 r above the floor to r below it
  c.sim.duration = 10 * *c.sim.dt;
  const Status s = runToEnd(c);
  expectReport(s, "tunnelling:", "particle 0 ");
  EXPECT_NE(s.message().find("plane 'floor'"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find(" at step 1 "), std::string::npos) << s.message();
}

// The same through a mesh floor (two triangles): the centre's path crosses a face within the step.
TEST(Instability, TunnellingThroughMeshFace) {
  RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, 0.9)};
  const double r = 0.01;
  addParticle(c, {0.013, 0.021, 2 * r}, r, 0, {0, 0, -50});
  compute::MeshConfig m;
  m.name = "tray";
  m.vertices = {{-0.1, -0.1, 0}, {0.1, -0.1, 0}, {0.1, 0.1, 0}, {-0.1, 0.1, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  c.meshes = {m};
  c.sim.gravity = {0, 0, 0};
  c.sim.dt = 2.5 * r / 50;  // ends half a radius below the face: still a candidate, centre through
  c.sim.duration = 10 * *c.sim.dt;
  const Status s = runToEnd(c);
  expectReport(s, "tunnelling:", "particle 0 ");
  EXPECT_NE(s.message().find("mesh 'tray'"), std::string::npos) << s.message();
}

// A particle flying out of a stated simulation.domain; a derived domain (no simulation.domain) is no
// boundary.
TEST(Instability, LeavingStatedDomain) {
  RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, 0.9)};
  const double r = 0.01;
  addParticle(c, {0.5, 0.5, 0.5}, r, 0);
  addParticle(c, {0.2, 0.3, 0.5}, r, 0, {3, 0, 0});
  c.sim.gravity = {0, 0, 0};
  c.sim.dt = 1e-4;
  c.sim.duration = 0.5;  // particle 1 reaches x = 1 at t = 0.267 s
  RunConfig derived = c;
  c.sim.domain = compute::Aabb{{0, 0, 0}, {1, 1, 1}};
  const Status s = runToEnd(c);
  expectReport(s, "left the domain:", "particle 1 ");
  EXPECT_NE(s.message().find("simulation.domain"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("(t = 0.26"), std::string::npos) << s.message();
  EXPECT_TRUE(runToEnd(derived).isOk());
}

// Two soft spheres colliding head-on at 4 m/s overlap by about 14 % of the radius (stable, resolved):
// fine with the default limit (50 %), an error naming both with simulation.max_overlap = 0.05.
TEST(Instability, OverlapBeyondStatedFraction) {
  RunConfig c;
  c.materials = {material("rubber", 1e7, 0.45, 1100, 0.9)};
  const double r = 0.01;
  addParticle(c, {0, 0, 0}, r, 0, {2, 0, 0});
  addParticle(c, {2.2 * r, 0, 0}, r, 0, {-2, 0, 0});
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 0.02;
  ASSERT_TRUE(runToEnd(c).isOk());
  c.sim.maxOverlap = 0.05;
  const Status s = runToEnd(c);
  expectReport(s, "excessive overlap:", "particle 0 ");
  EXPECT_NE(s.message().find("particle 1"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("simulation.max_overlap: 5.0%"), std::string::npos) << s.message();
}

// A particle with six contacts (an octahedral cluster, each neighbour slightly overlapping) and a cap of
// three: the slots may not grow past the cap, and the error names the crowded particle and its contacts.
TEST(Instability, ContactSlotCapExceeded) {
  RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, 0.5, 0.3)};  // friction: contacts keep history slots
  const double r = 0.01, d = 2 * r * 0.999;
  addParticle(c, {0, 0, 0}, r, 0);
  for (int axis = 0; axis < 3; ++axis)
    for (double sign : {-1.0, 1.0}) {
      Vec3d x{0, 0, 0};
      (axis == 0 ? x.x : axis == 1 ? x.y : x.z) = sign * d;
      addParticle(c, x, r, 0);
    }
  c.sim.gravity = {0, 0, 0};
  c.sim.historySlots = 1;
  c.sim.duration = 1e-5;
  ASSERT_TRUE(runToEnd(c).isOk());  // the default cap (64): slots grow, a log line
  c.sim.maxContacts = 3;
  const Status s = runToEnd(c);
  expectReport(s, "contact-slot overflow:", "particle 0 ");
  EXPECT_NE(s.message().find("has 6 simultaneous contacts"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("simulation.max_contacts (3)"), std::string::npos) << s.message();
}

// reduce_dt: the run that `stop` ends at a too-large dt goes back to its last checkpoint, halves dt until
// it is stable, and reaches the requested end time exactly, with outputs at the scheduled times.
TEST(Instability, ReduceDtRecoversAndKeepsTime) {
  RunConfig c = compressedBlock(1.5, 0.9);
  c.sim.duration = 1000 * *c.sim.dt;
  c.sim.checkpointSteps = 50;
  const Status stopped = runToEnd(c);
  ASSERT_FALSE(stopped.isOk());
  ASSERT_EQ(stopped.code(), StatusCode::kNumerical);

  c.sim.onInstability = compute::OnInstability::kReduceDt;
  auto sim = Simulation::create(c);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  Simulation& s = *sim.value();
  const double interval = 100 * *c.sim.dt;
  s.scheduleOutput(interval, c.sim.duration);
  std::vector<double> outputs;
  const Status run = s.runUntil(c.sim.duration, [&](const Simulation& x) {
    if (x.outputDue()) outputs.push_back(x.time());
    return Status::ok();
  });
  ASSERT_TRUE(run.isOk()) << run.toString();
  std::printf("reduce_dt: %d reductions, dt %.4g s -> %.4g s, %lld steps, t = %.9g s\n", s.dtReductions(), *c.sim.dt, s.dt(),
              (long long)s.stepCount(), s.time());
  EXPECT_GE(s.dtReductions(), 1);
  EXPECT_LE(s.dtReductions(), Simulation::kMaxDtReductions);
  EXPECT_DOUBLE_EQ(s.dt(), *c.sim.dt / std::pow(2.0, s.dtReductions()));
  EXPECT_NEAR(s.time(), c.sim.duration, 1e-9 * c.sim.duration);
  // Outputs every `interval` (none lost, none repeated), the last at the end.
  ASSERT_EQ(outputs.size(), 10u);
  for (std::size_t k = 0; k < outputs.size(); ++k) EXPECT_NEAR(outputs[k], double(k + 1) * interval, 1e-9 * interval) << k;
}

// reduce_dt gives up after a bounded number of halvings, with the detector's error.
TEST(Instability, ReduceDtGivesUp) {
  RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, 0.9)};
  const double r = 0.01;
  addParticle(c, {0.5, 0.5, 0.5}, r, 0, {3, 0, 0});  // leaves the domain at any dt
  c.sim.gravity = {0, 0, 0};
  c.sim.domain = compute::Aabb{{0, 0, 0}, {1, 1, 1}};
  c.sim.dt = 1e-3;
  c.sim.duration = 0.3;
  c.sim.checkpointSteps = 1000;
  c.sim.onInstability = compute::OnInstability::kReduceDt;
  const Status s = runToEnd(c);
  expectReport(s, "left the domain:", "particle 0 ");
  EXPECT_NE(s.message().find("gave up after 6 time-step reductions"), std::string::npos) << s.message();
}

// Legitimate scenes do not trip the detectors: a bed settling under gravity from a loose lattice, with a
// few particles starting overlapped (elastic energy released), and an elastic compressed block at the
// recommended step (its stored energy turns into motion and back).
TEST(Instability, SettlingBedDoesNotTrip) {
  RunConfig c;
  c.materials = {material("rubber", 1e7, 0.45, 1100, 0.5, 0.5)};
  const double r = 0.005;
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i)
        addParticle(c, {r + i * 2.3 * r + 0.1 * r * (k % 2), r + j * 2.3 * r, r + k * 2.4 * r}, r, 0);
  const Vec3d top = c.particles.position[5 * 9 + 4];
  addParticle(c, top + Vec3d{0, 0, 1.9 * r}, r, 0);  // starts overlapping a top-layer particle by 10 % of the radius
  const double side = 2 * r + 2 * 2.3 * r + 0.2 * r;
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor"), plane({0, 0, 0}, {1, 0, 0}, 0, "x0"),
              plane({side, 0, 0}, {-1, 0, 0}, 0, "x1"), plane({0, 0, 0}, {0, 1, 0}, 0, "y0"),
              plane({0, side, 0}, {0, -1, 0}, 0, "y1")};
  c.sim.duration = 0.3;
  std::unique_ptr<Simulation> sim;
  const Status s = runToEnd(c, &sim);
  ASSERT_TRUE(s.isOk()) << s.toString();
  std::printf("settled: %lld steps, kinetic energy %.3g J\n", (long long)sim->stepCount(), sim->contactStats().kineticEnergy);

  const RunConfig block = compressedBlock(0.2);  // the recommended step, elastic
  const Status b = runToEnd(block);
  EXPECT_TRUE(b.isOk()) << b.toString();
}

// A mesh plate moving into a row of particles on a floor pushes them (work done on them): no detector trips.
TEST(Instability, MovingMeshPushingParticlesDoesNotTrip) {
  RunConfig c;
  c.materials = {material("rubber", 1e7, 0.45, 1100, 0.5, 0.5)};
  const double r = 0.005;
  for (int i = 0; i < 5; ++i) addParticle(c, {0.02 + i * 2.05 * r, 0, r * 0.999}, r, 0);
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
  compute::MeshConfig m;
  m.name = "pusher";
  m.vertices = {{0.01, -0.02, 0}, {0.01, 0.02, 0}, {0.01, 0.02, 0.02}, {0.01, -0.02, 0.02}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};  // normal +x, towards the particles
  m.motion.velocity = {0.2, 0, 0};
  c.meshes = {m};
  c.sim.domain = compute::Aabb{{-0.05, -0.05, -0.05}, {0.2, 0.05, 0.05}};
  c.sim.duration = 0.15;  // the plate travels 3 cm: it reaches the row and pushes it
  std::unique_ptr<Simulation> sim;
  const Status s = runToEnd(c, &sim);
  ASSERT_TRUE(s.isOk()) << s.toString();
  const auto snap = sim->snapshot({"position"});
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  double minX = 1;
  for (std::size_t i = 0; i < snap.n; ++i) minX = std::min(minX, x[i].x);
  std::printf("pushed: leftmost particle at x = %.4g m (plate at %.4g m)\n", minX, 0.01 + 0.2 * c.sim.duration);
  EXPECT_GT(minX, 0.01 + 0.2 * c.sim.duration);  // in front of the plate: pushed, not passed through
}

// The settings are validated together, and reduce_dt is refused for a run over several ranks.
TEST(Instability, SettingsAreValidated) {
  RunConfig c = compressedBlock(0.2);
  c.sim.maxOverlap = 1.5;
  c.sim.maxContacts = 4;  // below history_slots (8)
  c.sim.checkpointSteps = 0;
  const ErrorList errors = c.validate();
  const std::string all = errors.toStatus("invalid").message();
  EXPECT_NE(all.find("simulation.max_overlap"), std::string::npos) << all;
  EXPECT_NE(all.find("simulation.max_contacts"), std::string::npos) << all;
  EXPECT_NE(all.find("simulation.checkpoint_steps"), std::string::npos) << all;

  struct TwoRanks : compute::Domain {
    int ranks() const override { return 2; }
  };
  RunConfig r = compressedBlock(0.2);
  r.sim.onInstability = compute::OnInstability::kReduceDt;
  compute::SimulationOptions o;
  o.domain = std::make_shared<TwoRanks>();
  auto sim = Simulation::create(r, o);
  ASSERT_FALSE(sim.isOk());
  EXPECT_NE(sim.status().message().find("reduce_dt runs in one process only"), std::string::npos) << sim.status().toString();
}

}  // namespace
}  // namespace pflow::test
