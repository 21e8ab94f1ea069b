// solver: sph scenes: the examples load with the documented particle counts; bad input gets one precise error
// per problem, all at once, naming the key (docs/scene-format.md, "Fluids").
#include <gtest/gtest.h>

#include <string>

#include "frontend/SceneLoader.h"
#include "frontend/SceneSummary.h"

namespace pflow::frontend {
namespace {

// The 2D dam break with `sph` and `fluid` overridable, as text.
std::string damBreak(const std::string& sph = "{dimension: 2, spacing: 0.01}", const std::string& fluid = "density: 1000",
                     const std::string& tank = "{min: [0, 0, 0], max: [1.0, 0, 0.6]}", const std::string& block = "{min: [0, 0, 0], max: [0.2, 0, 0.4]}") {
  return "solver: sph\n"
         "fluid:\n  " + fluid + "\n  blocks:\n    - " + block + "\n"
         "tank: " + tank + "\n"
         "sph: " + sph + "\n"
         "simulation: {duration: 1.0, snapshot_interval: 0.05}\n";
}

Result<LoadedScene> load(const std::string& yaml) { return loadSceneFromString(yaml, "case.yaml"); }

TEST(SphScene, ExampleLoadsAtTheSeedsResolution) {
  auto r = loadScene("examples/dam_break_2d.yaml");
  ASSERT_TRUE(r.isOk()) << r.status().message();
  const compute::RunConfig& c = r.value().config;
  EXPECT_EQ(c.solver, compute::Solver::kSph);
  EXPECT_EQ(c.sph.fluidCount(), 20u * 40u);
  EXPECT_EQ(c.sph.dimension, 2);
  ASSERT_TRUE(c.sph.tank.has_value());
  // Three layers of walls (2h/dp = 3) under and beside the tank's inside, none over its open top.
  EXPECT_EQ(c.sph.size() - c.sph.fluidCount(), std::size_t(3 * (100 + 6) + 2 * 3 * 120));
  for (const Vec3d& x : c.sph.position) EXPECT_EQ(x.y, 0.0);
}

TEST(SphScene, RefinedResolutionIsOneKey) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.002}"));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r.value().config.sph.fluidCount(), 100u * 200u);
}

// simulation.reproducible is an SPH key too (each pair once on one GPU in float); the benchmark example sets it false.
TEST(SphScene, ReproducibleIsRead) {
  auto r = load(damBreak());
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_TRUE(r.value().config.sim.reproducible);
  std::string yaml = damBreak();
  yaml.replace(yaml.find("snapshot_interval: 0.05}"), 24, "snapshot_interval: 0.05, reproducible: false}");
  auto off = load(yaml);
  ASSERT_TRUE(off.isOk()) << off.status().message();
  EXPECT_FALSE(off.value().config.sim.reproducible);
  auto example = loadScene("examples/dam_break_3d.yaml");
  ASSERT_TRUE(example.isOk()) << example.status().message();
  EXPECT_FALSE(example.value().config.sim.reproducible);
}

// SPHERIC test 2's instruments (Kleefsman et al. 2005; the SPHERIC distribution's positions, docs/sph.md): P1-P4 up
// the box's front face, P5-P8 along its top from the front edge, the gauges H1-H4 along the tank's centre line.
TEST(SphScene, SphericExampleHasTheEightProbesAndFourGauges) {
  auto example = loadScene("examples/dam_break_3d.yaml");
  ASSERT_TRUE(example.isOk()) << example.status().message();
  const auto& probes = example.value().config.sph.probes;
  ASSERT_EQ(probes.size(), 12u);
  const double face[4][3] = {{0.8245, 0.471, 0.021}, {0.8245, 0.471, 0.061}, {0.8245, 0.471, 0.101}, {0.8245, 0.471, 0.141}};
  const double top[4][3] = {{0.8035, 0.471, 0.161}, {0.7635, 0.471, 0.161}, {0.7235, 0.471, 0.161}, {0.6835, 0.471, 0.161}};
  for (int i = 0; i < 8; ++i) {
    const auto& p = probes[i];
    const double* want = i < 4 ? face[i] : top[i - 4];
    EXPECT_EQ(p.name, "P" + std::to_string(i + 1));
    EXPECT_FALSE(p.gauge) << p.name;
    EXPECT_EQ(p.point.x, want[0]) << p.name;
    EXPECT_EQ(p.point.y, want[1]) << p.name;
    EXPECT_EQ(p.point.z, want[2]) << p.name;
  }
  const double gaugeX[4] = {0.496, 0.992, 1.488, 2.638};
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(probes[8 + i].name, "H" + std::to_string(i + 1));
    EXPECT_TRUE(probes[8 + i].gauge);
    EXPECT_EQ(probes[8 + i].point.x, gaugeX[i]);
  }
}

TEST(SphScene, MissingDensityIsNamed) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.01}", "sound_speed: auto"));
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("fluid.density: required key 'density' is missing"), std::string::npos) << r.status().message();
}

TEST(SphScene, SmoothingRatioOutOfRange) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.01, smoothing_ratio: 0.6}"));
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("sph.smoothing_ratio: 0.6 is outside [1, 3]"), std::string::npos) << r.status().message();
}

TEST(SphScene, ColumnNotResolved) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.04}"));
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("fluid.blocks[0]: its smallest extent 0.2 m is under 4 smoothing lengths"), std::string::npos)
      << r.status().message();
}

TEST(SphScene, TankMustContainTheFluid) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.01}", "density: 1000", "{min: [0.1, 0, 0], max: [1.0, 0, 0.6]}"));
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("fluid.blocks[0]: reaches outside the tank"), std::string::npos) << r.status().message();
}

TEST(SphScene, SoundSpeedBelowTenTimesTheFlow) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.01}", "density: 1000\n  sound_speed: 10"));
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("fluid.sound_speed: 10 m/s is below 10 x the expected maximum speed 3.96"), std::string::npos)
      << r.status().message();
}

// Every problem at once, each with its key and line: a kernel that does not exist, a negative density, an
// unknown key (with a suggestion) and a block that is not flat in a 2D run.
TEST(SphScene, EveryErrorAtOnce) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.01, kernel: gaussian, cfll: 0.2}", "density: -5", "{min: [0, 0, 0], max: [1.0, 0, 0.6]}",
                         "{min: [0, 0, 0], max: [0.2, 0.1, 0.4]}"));
  ASSERT_FALSE(r.isOk());
  const std::string m = r.status().message();
  EXPECT_NE(m.find("sph.kernel"), std::string::npos) << m;
  EXPECT_NE(m.find("wendland, cubic_spline"), std::string::npos) << m;
  EXPECT_NE(m.find("sph.cfll"), std::string::npos) << m;
  EXPECT_NE(m.find("'cfl'"), std::string::npos) << m;
  EXPECT_NE(m.find("fluid.blocks[0].max"), std::string::npos) << m;
  EXPECT_NE(m.find("line 3, column 12: fluid.density: -5"), std::string::npos) << m;
  // DEM sections are not SPH's: a materials list is an unknown key here.
  auto dem = load(damBreak() + "materials: []\n");
  ASSERT_FALSE(dem.isOk());
  EXPECT_NE(dem.status().message().find("materials"), std::string::npos);
}

// The services' summary (what pflow submit builds its job from): the particles of both kinds, the first CFL
// step and the steps to the end, memory from the SPH field table, the method as the model's decisions.
TEST(SphScene, SummaryForTheServices) {
  auto r = load(damBreak());
  ASSERT_TRUE(r.isOk()) << r.status().message();
  auto summary = summarize(r.value());
  ASSERT_TRUE(summary.isOk()) << summary.status().message();
  const SceneSummary& s = summary.value();
  EXPECT_EQ(s.solver, "sph");
  EXPECT_EQ(s.particles, r.value().config.sph.size());
  ASSERT_EQ(s.sets.size(), 2u);
  EXPECT_EQ(s.sets[0].info.count, 800u);
  EXPECT_EQ(s.sets[0].info.name, "fluid");
  EXPECT_EQ(s.sets[1].info.count, s.particles - 800u);
  EXPECT_NEAR(s.dt, 7.572e-5, 1e-8);  // CFL 0.2 x h / c0 = 0.2 x 0.015 / 39.62
  EXPECT_NEAR(double(s.steps), 13206, 1);  // 1 s of the first step (the count is an estimate: dt follows the flow)
  // The engine's buffers in double (SphSummary.cc lists them): 337 B (pflow-sph-bench measures them with the
  // buffers' growth slack: bench/RESULTS.md).
  EXPECT_EQ(s.bytesPerParticle, 337.0);
  EXPECT_EQ(s.memoryBytes, s.bytesPerParticle * double(s.particles) + 4.0 * (s.cells[0] * s.cells[1] * s.cells[2] + 1));
  EXPECT_NE(s.model.text().find("solver: sph"), std::string::npos) << s.model.text();
  EXPECT_NE(toJson(s).find("\"solver\":\"sph\""), std::string::npos);
  // Float: 229 B.
  std::string yaml = damBreak();
  yaml.replace(yaml.find("simulation: {"), 13, "simulation: {precision: float, ");
  auto single = load(yaml);
  ASSERT_TRUE(single.isOk()) << single.status().message();
  EXPECT_EQ(summarize(single.value()).value().bytesPerParticle, 229.0);
}

// Mirror walls: no wall particles, the tank recorded; the keys that do not go with them are named.
TEST(SphScene, MirrorWallsAndTheirErrors) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.01, boundary: mirror, wall_slip: free_slip}"));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  const compute::sph::SphConfig& c = r.value().config.sph;
  EXPECT_EQ(c.size(), 800u);
  EXPECT_EQ(c.boundary, compute::sph::BoundaryKind::kMirror);
  EXPECT_TRUE(c.freeSlip);
  ASSERT_TRUE(c.tank.has_value());
  EXPECT_TRUE(c.tankOpenTop);
  auto bad = load("solver: sph\nfluid:\n  density: 1000\n  blocks:\n    - {min: [0, 0, 0], max: [0.2, 0, 0.4]}\n"
                  "sph: {dimension: 2, spacing: 0.01, boundary: mirror, boundary_layers: 3}\nsimulation: {duration: 1.0}\n");
  ASSERT_FALSE(bad.isOk());
  const std::string m = bad.status().message();
  EXPECT_NE(m.find("sph.boundary: mirror walls are the tank's walls: give a tank"), std::string::npos) << m;
  EXPECT_NE(m.find("sph.boundary_layers: applies to dynamic walls"), std::string::npos) << m;
  auto slip = load(damBreak("{dimension: 2, spacing: 0.01, wall_slip: free_slip}"));
  ASSERT_FALSE(slip.isOk());
  EXPECT_NE(slip.status().message().find("sph.wall_slip: applies to mirror walls"), std::string::npos) << slip.status().message();
  auto unknown = load(damBreak("{dimension: 2, spacing: 0.01, boundary: ghost}"));
  ASSERT_FALSE(unknown.isOk());
  EXPECT_NE(unknown.status().message().find("dynamic, mirror"), std::string::npos) << unknown.status().message();
}

// sph.boundary_density: continuity (the default) or mdbc; a bad name, and mdbc where there are no boundary particles
// (mirror walls, no obstacle), are named.
TEST(SphScene, BoundaryDensityAndItsErrors) {
  auto plain = load(damBreak());
  ASSERT_TRUE(plain.isOk()) << plain.status().message();
  EXPECT_FALSE(plain.value().config.sph.mdbc);
  auto mdbc = load(damBreak("{dimension: 2, spacing: 0.01, boundary_density: mdbc}"));
  ASSERT_TRUE(mdbc.isOk()) << mdbc.status().message();
  EXPECT_TRUE(mdbc.value().config.sph.mdbc);
  auto unknown = load(damBreak("{dimension: 2, spacing: 0.01, boundary_density: ghost}"));
  ASSERT_FALSE(unknown.isOk());
  EXPECT_NE(unknown.status().message().find("sph.boundary_density"), std::string::npos) << unknown.status().message();
  EXPECT_NE(unknown.status().message().find("continuity, mdbc"), std::string::npos) << unknown.status().message();
  auto none = load(damBreak("{dimension: 2, spacing: 0.01, boundary: mirror, boundary_density: mdbc}"));
  ASSERT_FALSE(none.isOk());
  EXPECT_NE(none.status().message().find("sph.boundary_density: mdbc applies to boundary particles"), std::string::npos)
      << none.status().message();
}

// sph.integrator picks the time integration; a bad name and sph.verlet_steps without Verlet are named.
TEST(SphScene, IntegratorAndItsErrors) {
  auto r = load(damBreak("{dimension: 2, spacing: 0.01, integrator: verlet, verlet_steps: 50}"));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r.value().config.sph.integrator, compute::sph::Integrator::kVerlet);
  EXPECT_EQ(r.value().config.sph.verletSteps, 50);
  auto unknown = load(damBreak("{dimension: 2, spacing: 0.01, integrator: leapfrog, verlet_steps: 0.5}"));
  ASSERT_FALSE(unknown.isOk());
  const std::string m = unknown.status().message();
  EXPECT_NE(m.find("symplectic, verlet, velocity_verlet"), std::string::npos) << m;
  EXPECT_NE(m.find("sph.verlet_steps: 0.5 is not a whole number"), std::string::npos) << m;
  auto kdk = load(damBreak("{dimension: 2, spacing: 0.01, integrator: velocity_verlet}"));
  ASSERT_TRUE(kdk.isOk()) << kdk.status().message();
  EXPECT_EQ(kdk.value().config.sph.integrator, compute::sph::Integrator::kVelocityVerlet);
  auto stray = load(damBreak("{dimension: 2, spacing: 0.01, verlet_steps: 20}"));
  ASSERT_FALSE(stray.isOk());
  EXPECT_NE(stray.status().message().find("sph.verlet_steps: applies to sph.integrator: verlet"), std::string::npos)
      << stray.status().message();
}

// output.probe_sampling: instant (the default) or mean; anything else is named with the choices.
TEST(SphScene, ProbeSamplingAndItsError) {
  auto plain = load(damBreak());
  ASSERT_TRUE(plain.isOk()) << plain.status().message();
  EXPECT_FALSE(plain.value().config.sph.probeMean);
  auto mean = load(damBreak() + "output: {probe_interval: 0.001, probe_sampling: mean}\n");
  ASSERT_TRUE(mean.isOk()) << mean.status().message();
  EXPECT_TRUE(mean.value().config.sph.probeMean);
  EXPECT_EQ(mean.value().config.sph.probeInterval, 0.001);
  auto bad = load(damBreak() + "output: {probe_sampling: average}\n");
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("output.probe_sampling"), std::string::npos) << bad.status().message();
  EXPECT_NE(bad.status().message().find("instant, mean"), std::string::npos) << bad.status().message();
}

TEST(SphScene, UnknownSolverIsNamed) {
  auto r = load("solver: fem\nsimulation: {duration: 1}\n");
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("solver"), std::string::npos);
  EXPECT_NE(r.status().message().find("dem, sph"), std::string::npos) << r.status().message();
}

}  // namespace
}  // namespace pflow::frontend
