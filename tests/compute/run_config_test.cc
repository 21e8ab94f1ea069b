// RunConfig::validate() and the time-step functions (compute/dem/TimeStep.h).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "compute/sim/RunConfig.h"
#include "compute/dem/Simulation.h"
#include "compute/dem/TimeStep.h"

namespace pflow::compute {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The benchmark material (benchmarks.md): d = 1 mm, rho = 2500, E = 1e7, nu = 0.3.
MaterialConfig benchMaterial() {
  MaterialConfig m;
  m.name = "bench";
  m.youngsModulus = 1e7;
  m.poissonRatio = 0.3;
  m.density = 2500;
  m.restitution = 0.5;
  m.friction = 0.5;
  return m;
}

// One material, a floor at z = 0 and `n` particles of radius 0.5 mm in a row above it.
RunConfig validConfig(std::size_t n = 3) {
  RunConfig c;
  c.materials.push_back(benchMaterial());
  for (std::size_t i = 0; i < n; ++i) {
    c.particles.position.push_back({0.0011 * static_cast<double>(i), 0, 0.001});
    c.particles.radius.push_back(0.0005);
    c.particles.material.push_back(0);
  }
  c.planes.push_back({"floor", {0, 0, 0}, {0, 0, 1}, 0});
  c.sim.duration = 0.1;
  return c;
}

bool hasError(const ErrorList& errors, const std::string& path, const std::string& messagePart) {
  for (const FieldError& e : errors.errors()) {
    if (e.path == path && e.message.find(messagePart) != std::string::npos) return true;
  }
  return false;
}

#define EXPECT_ERROR(errors, path, part) EXPECT_TRUE(hasError(errors, path, part)) << "want " << path << ": ..." << part << "...\ngot:\n" << (errors).toString()

TEST(RunConfigValidate, ValidConfigHasNoErrors) {
  const ErrorList errors = validConfig().validate();
  EXPECT_TRUE(errors.empty()) << errors.toString();
}

TEST(RunConfigValidate, ReportsEveryMaterialProblemAtOnce) {
  RunConfig c = validConfig();
  MaterialConfig& m = c.materials[0];
  m.youngsModulus = -1e7;
  m.poissonRatio = 0.7;
  m.density = 0;
  m.restitution = 1.5;
  m.friction = -0.1;
  m.rollingFriction = -0.2;
  const ErrorList errors = c.validate();
  EXPECT_EQ(errors.size(), 6u) << errors.toString();
  EXPECT_TRUE(hasError(errors, "materials[0].poisson_ratio", "0.7 is outside (-1, 0.5)"));
  EXPECT_ERROR(errors, "materials[0].youngs_modulus", "-1e+07 must be > 0");
  EXPECT_ERROR(errors, "materials[0].density", "0 must be > 0");
  EXPECT_ERROR(errors, "materials[0].restitution", "1.5 is outside (0, 1]");
  EXPECT_ERROR(errors, "materials[0].friction", "-0.1 must be >= 0");
  EXPECT_ERROR(errors, "materials[0].rolling_friction", "-0.2 must be >= 0");
  // The formatted line a user sees.
  EXPECT_NE(errors.toString().find("materials[0].poisson_ratio: 0.7 is outside (-1, 0.5)"), std::string::npos);
}

TEST(RunConfigValidate, MaterialBoundsAreExactlyAsDocumented) {
  auto errorsFor = [](double nu, double e) {
    RunConfig c = validConfig();
    c.materials[0].poissonRatio = nu;
    c.materials[0].restitution = e;
    return c.validate();
  };
  EXPECT_TRUE(errorsFor(0.4999, 1.0).empty());   // e = 1 allowed
  EXPECT_TRUE(errorsFor(-0.9999, 1e-6).empty());
  EXPECT_ERROR(errorsFor(0.5, 0.5), "materials[0].poisson_ratio", "0.5 is outside (-1, 0.5)");
  EXPECT_ERROR(errorsFor(-1.0, 0.5), "materials[0].poisson_ratio", "-1 is outside (-1, 0.5)");
  EXPECT_ERROR(errorsFor(0.3, 0.0), "materials[0].restitution", "0 is outside (0, 1]");
  EXPECT_ERROR(errorsFor(kNaN, 0.5), "materials[0].poisson_ratio", "nan is not a finite number");
}

TEST(RunConfigValidate, NeedsAMaterialAndUniqueNames) {
  RunConfig c = validConfig(0);
  c.planes.clear();
  c.materials.clear();
  EXPECT_ERROR(c.validate(), "materials", "at least one material");
  c.materials = {benchMaterial(), benchMaterial()};
  EXPECT_ERROR(c.validate(), "materials[1].name", "'bench' is already the name of materials[0]");
}

// Particles of a fixed material do not move: a velocity or a spin given to one is an error naming it; only the first
// 64 materials may be fixed (a bit each).
TEST(RunConfigValidate, FixedParticlesAreNotGivenMotion) {
  RunConfig c = validConfig(3);
  MaterialConfig glued = benchMaterial();
  glued.name = "glued";
  glued.fixed = true;
  c.materials.push_back(glued);
  c.particles.material = {1, 1, 0};
  c.particles.velocity = {{0, 0, 0}, {0, 0, -1}, {0, 0, -1}};
  c.particles.angularVelocity = {{1, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  const ErrorList errors = c.validate();
  EXPECT_ERROR(errors, "particles.velocity[0]", "material glued is fixed");
  EXPECT_ERROR(errors, "particles.velocity[1]", "material glued is fixed");
  EXPECT_FALSE(hasError(errors, "particles.velocity[2]", "fixed")) << errors.toString();
  c.particles.velocity.clear();
  c.particles.angularVelocity.clear();
  EXPECT_TRUE(c.validate().empty()) << c.validate().toString();
  for (int k = 0; k < 64; ++k) {
    MaterialConfig m = benchMaterial();
    m.name = "m" + std::to_string(k);
    c.materials.push_back(m);
  }
  c.materials.back().fixed = true;  // the 66th
  EXPECT_ERROR(c.validate(), "materials[65].fixed", "only the first 64 materials may be fixed");
}

TEST(RunConfigValidate, PairIndicesAndOverrides) {
  RunConfig c = validConfig();
  MaterialPairConfig p;
  p.a = 0;
  p.b = 3;
  p.restitution = 0.0;
  p.friction = -1.0;
  p.rollingFriction = 0.1;
  c.pairs.push_back(p);
  MaterialPairConfig dup;
  dup.a = 3;
  dup.b = 0;
  c.pairs.push_back(dup);
  const ErrorList errors = c.validate();
  EXPECT_ERROR(errors, "pairs[0].materials[1]", "3 is not a material index");
  EXPECT_ERROR(errors, "pairs[0].restitution", "0 is outside (0, 1]");
  EXPECT_ERROR(errors, "pairs[0].friction", "-1 must be >= 0");
  EXPECT_ERROR(errors, "pairs[1]", "same material pair as pairs[0]");
  EXPECT_FALSE(hasError(errors, "pairs[0].rolling_friction", ""));
}

TEST(RunConfigValidate, ParticleArraysMustAgree) {
  RunConfig c = validConfig(4);
  c.particles.velocity.resize(2, Vec3d{0, 0, 0});
  c.particles.angularVelocity.resize(4, Vec3d{0, 0, 0});  // same length: fine
  c.particles.radius.pop_back();
  const ErrorList errors = c.validate();
  EXPECT_ERROR(errors, "particles.velocity", "has 2 entries; expected 0 (all zero) or 4");
  EXPECT_ERROR(errors, "particles.radius", "has 3 entries; expected 4");
  EXPECT_FALSE(hasError(errors, "particles.angular_velocity", ""));
}

TEST(RunConfigValidate, ParticleRadiusMaterialAndNonFiniteValuesNameTheEntry) {
  RunConfig c = validConfig(14);
  c.particles.radius[12] = -0.001;
  c.particles.radius[3] = kNaN;
  c.particles.material[5] = 7;
  c.particles.position[2] = {kNaN, 0, 0.001};
  c.particles.velocity.assign(14, Vec3d{0, 0, 0});
  c.particles.velocity[9] = {0, kInf, 0};
  c.particles.angularVelocity.assign(14, Vec3d{0, 0, 0});
  c.particles.angularVelocity[1] = {0, 0, -kInf};
  c.sim.gravity = {0, 0, kNaN};
  c.planes[0].point = {kNaN, 0, 0};
  const ErrorList errors = c.validate();
  EXPECT_NE(errors.toString().find("particles.radius[12]: -0.001 must be > 0"), std::string::npos) << errors.toString();
  EXPECT_ERROR(errors, "particles.radius[3]", "nan is not a finite number");
  EXPECT_ERROR(errors, "particles.material[5]", "7 is not a material index (there is 1 material)");
  EXPECT_ERROR(errors, "particles.position[2]", "[nan, 0, 0.001] is not finite");
  EXPECT_ERROR(errors, "particles.velocity[9]", "[0, inf, 0] is not finite");
  EXPECT_ERROR(errors, "particles.angular_velocity[1]", "[0, 0, -inf] is not finite");
  EXPECT_ERROR(errors, "simulation.gravity", "[0, 0, nan] is not finite");
  EXPECT_ERROR(errors, "planes[0].point", "[nan, 0, 0] is not finite");
}

TEST(RunConfigValidate, ManyBadParticlesAreCappedWithASummary) {
  RunConfig c = validConfig(5000);
  for (double& r : c.particles.radius) r = -0.001;
  c.particles.radius[0] = 0.0005;
  const ErrorList errors = c.validate();
  std::size_t radiusErrors = 0;
  for (const FieldError& e : errors.errors()) {
    if (e.path.rfind("particles.radius[", 0) == 0) ++radiusErrors;
  }
  EXPECT_EQ(radiusErrors, 20u);
  EXPECT_ERROR(errors, "particles.radius", "... and 4979 more particles with radius <= 0");
  EXPECT_EQ(errors.size(), 21u) << errors.toString();
}

TEST(RunConfigValidate, ParticleBehindOrDeepInAPlane) {
  RunConfig c = validConfig(4);
  c.particles.position[0].z = -0.0001;   // centre behind the floor
  c.particles.position[1].z = 0.0004;    // overlaps 0.1 mm = 20 % of its radius
  c.particles.position[2].z = 0.000475;  // overlaps 5 %: allowed
  c.particles.position[3].z = 0.0005;    // touching: allowed
  const ErrorList errors = c.validate();
  EXPECT_EQ(errors.size(), 2u) << errors.toString();
  EXPECT_ERROR(errors, "particles.position[0]", "lies behind plane 'floor' (planes[0]) by 0.0001 m");
  EXPECT_ERROR(errors, "particles.position[1]", "starts overlapping plane 'floor' (planes[0]) by 0.0001 m (20% of its radius");
}

TEST(RunConfigValidate, PlaneChecksUseTheNormalisedNormal) {
  RunConfig c = validConfig(1);
  c.planes[0].normal = {0, 0, 1000};  // not unit length: distances must still be in metres
  c.particles.position[0].z = 0.00046;  // overlap 8 %
  EXPECT_TRUE(c.validate().empty()) << c.validate().toString();
  c.planes[0].normal = {0, 0, 0};
  EXPECT_ERROR(c.validate(), "planes[0].normal", "must be nonzero");
}

TEST(RunConfigValidate, FacingPlanesCloserThanTheSmallestDiameter) {
  RunConfig c = validConfig(1);
  c.particles.position[0] = {0, 0, 0.0006};
  c.planes.push_back({"lid", {0, 0, 0.0009}, {0, 0, -1}, 0});  // gap 0.9 mm < diameter 1 mm
  const ErrorList errors = c.validate();
  EXPECT_ERROR(errors, "planes[1]", "face each other only 0.0009 m apart, less than the smallest particle diameter 0.001 m");
  c.planes[1].point.z = 0.0012;
  EXPECT_TRUE(c.validate().empty()) << c.validate().toString();
  c.planes[1] = {"shelf", {0, 0, -0.5}, {0, 0, 1}, 0};  // parallel, same direction: not a slab
  EXPECT_TRUE(c.validate().empty()) << c.validate().toString();
  c.particles = {};
  c.planes[1] = {"below", {0, 0, -1}, {0, 0, -1}, 0};  // backs to each other: nothing in front of both
  EXPECT_ERROR(c.validate(), "planes[1]", "no point lies in front of both");
}

TEST(RunConfigValidate, MeshProblems) {
  RunConfig c = validConfig();
  MeshConfig m;
  m.name = "tri";
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {kNaN, 0, 0}};
  m.triangles = {{0, 1, 2}, {0, 1, 3}, {0, 1, 9}, {0, 0, 2}};
  m.surface = {0, 1};
  m.material = 2;
  m.motion.angularSpeed = 1.0;
  m.motion.axis = {0, 0, 0};
  m.motion.startTime = -1;
  c.meshes.push_back(m);
  const ErrorList errors = c.validate();
  EXPECT_ERROR(errors, "meshes[0].vertices[4]", "is not finite");
  EXPECT_ERROR(errors, "meshes[0].triangles[1]", "triangle [0, 1, 3] is degenerate (zero area)");
  EXPECT_ERROR(errors, "meshes[0].triangles[2]", "triangle [0, 1, 9] refers to a vertex outside [0, 5)");
  EXPECT_ERROR(errors, "meshes[0].triangles[3]", "triangle [0, 0, 2] is degenerate");
  EXPECT_ERROR(errors, "meshes[0].surfaces", "has 2 entries; expected 0 (all surface 0) or 4");
  EXPECT_ERROR(errors, "meshes[0].material", "2 is not a material index");
  EXPECT_ERROR(errors, "meshes[0].motion.axis", "must be nonzero when angular_velocity is 1");
  EXPECT_ERROR(errors, "meshes[0].motion.start_time", "-1 must be >= 0");
  EXPECT_FALSE(hasError(errors, "meshes[0].triangles[0]", ""));

  c.meshes[0] = MeshConfig{};
  EXPECT_ERROR(c.validate(), "meshes[0].triangles", "the mesh has no triangles");
}

TEST(RunConfigValidate, SimulationSettings) {
  RunConfig c = validConfig();
  c.sim.dt = 0.0;
  c.sim.duration = -1;
  c.sim.dtFraction = 1.5;
  c.sim.skin = 0;
  c.sim.snapshotInterval = -0.1;
  c.sim.domain = Aabb{{0, 0, 0}, {1, -1, 1}};
  c.sim.historySlots = 0;
  c.sim.wallHistorySlots = 33;
  c.sim.threads = -2;
  c.sim.rebuildInterval = -3;
  const ErrorList errors = c.validate();
  EXPECT_ERROR(errors, "simulation.dt", "0 must be > 0");
  EXPECT_ERROR(errors, "simulation.duration", "-1 must be > 0");
  EXPECT_ERROR(errors, "simulation.dt_fraction", "1.5 is outside (0, 1]");
  EXPECT_ERROR(errors, "simulation.skin", "0 is invalid");
  EXPECT_ERROR(errors, "simulation.snapshot_interval", "-0.1 must be >= 0");
  EXPECT_ERROR(errors, "simulation.domain", "max.y (-1) must be > min.y (0)");
  EXPECT_ERROR(errors, "simulation.history_slots", "0 is outside [1, 64]");
  EXPECT_ERROR(errors, "simulation.wall_history_slots", "33 is outside [1, 32]");
  EXPECT_ERROR(errors, "simulation.threads", "-2 must be >= 0");
  EXPECT_ERROR(errors, "simulation.rebuild_interval", "-3 must be >= 0");
  // Every particle is outside the (broken) domain, but that is not checked against a broken domain.
  EXPECT_FALSE(hasError(errors, "particles.position[0]", ""));

  c = validConfig();
  c.sim.dt = -1e-6;
  EXPECT_ERROR(c.validate(), "simulation.dt", "-1e-06 must be > 0");
  c.sim.dt = 1e-6;
  c.sim.skin = -1;  // auto
  c.sim.historySlots = 64;
  c.sim.wallHistorySlots = 1;
  EXPECT_TRUE(c.validate().empty()) << c.validate().toString();
  c.sim.domain = Aabb{{0, 0, 0}, {0.002, 0.001, 0.002}};  // particle 1 at x = 1.1 mm and 2 at 2.2 mm lie outside
  const ErrorList outside = c.validate();
  EXPECT_ERROR(outside, "particles.position[2]", "lies outside simulation.domain");
  EXPECT_FALSE(hasError(outside, "particles.position[0]", ""));
}

TEST(RunConfigValidate, LargeParticleCountsStayFast) {
  RunConfig c = validConfig(500000);
  for (int k = 0; k < 5; ++k) c.planes.push_back({"", {-1, -1, -1}, {0, 1, 0}, 0});
  const auto start = std::chrono::steady_clock::now();
  const ErrorList errors = c.validate();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(errors.empty()) << errors.toString();
  EXPECT_LT(seconds, 5.0);  // O(N * planes): a few ms; generous for a loaded machine
}

// ---- time step ----------------------------------------------------------------------------------------------------

TEST(TimeStep, RayleighTimeOfTheBenchmarkMaterial) {
  // benchmarks.md: d = 1 mm, rho = 2500, E = 1e7, nu = 0.3 -> T_R = 4.33e-5 s.
  EXPECT_NEAR(rayleighTime(0.0005, 2500, 1e7, 0.3), 4.33e-5, 0.01 * 4.33e-5);
}

TEST(TimeStep, HertzContactTimeOfChungOoiSpheres) {
  // Chung & Ooi 2011, test 1: identical spheres R = 10 mm at a relative 20 m/s.
  auto contactTime = [](double e, double nu, double rho) {
    const double r = 0.01;
    const double mass = rho * 4.0 / 3.0 * std::numbers::pi * r * r * r;
    const double eStar = e / (2.0 * (1.0 - nu * nu));
    return hertzContactTime(r / 2, mass / 2, eStar, 20.0);
  };
  EXPECT_NEAR(contactTime(48e9, 0.2, 2800), 40.3e-6, 0.01 * 40.3e-6);  // glass
  EXPECT_NEAR(contactTime(20e9, 0.25, 2500), 54.2e-6, 0.01 * 54.2e-6);  // limestone
}

TEST(TimeStep, AutomaticUsesTheSmallestParticleOverMaterials) {
  RunConfig c = validConfig(3);
  MaterialConfig stiff = benchMaterial();
  stiff.name = "stiff";
  stiff.youngsModulus = 1e9;
  c.materials.push_back(stiff);
  c.particles.radius[0] = 0.0002;  // smallest, soft material
  c.particles.material[2] = 1;     // stiff material, radius 0.5 mm: shorter T_R than the small soft one
  const double soft = rayleighTime(0.0002, 2500, 1e7, 0.3);
  const double hard = rayleighTime(0.0005, 2500, 1e9, 0.3);
  ASSERT_LT(hard, soft);
  const auto info = chooseTimeStep(c);
  ASSERT_TRUE(info.isOk()) << info.status().toString();
  EXPECT_TRUE(info->automatic);
  EXPECT_DOUBLE_EQ(info->rayleighTime, hard);
  EXPECT_DOUBLE_EQ(info->dt, 0.2 * hard);
  EXPECT_DOUBLE_EQ(info->fractionOfRayleigh, 0.2);
  EXPECT_TRUE(info->warnings.empty());
  EXPECT_NE(info->reason.find("'stiff'"), std::string::npos) << info->reason;
}

TEST(TimeStep, ExplicitDtAboveFortyPercentWarns) {
  RunConfig c = validConfig();
  c.sim.dt = 5e-6;  // the benchmark's 0.116 T_R
  auto info = chooseTimeStep(c);
  ASSERT_TRUE(info.isOk());
  EXPECT_FALSE(info->automatic);
  EXPECT_NEAR(info->fractionOfRayleigh, 0.1155, 0.001);
  EXPECT_TRUE(info->warnings.empty());

  c.sim.dt = 2.5e-5;  // 0.58 T_R
  info = chooseTimeStep(c);
  ASSERT_TRUE(info.isOk());
  ASSERT_EQ(info->warnings.size(), 1u);
  EXPECT_NE(info->warnings[0].find("is 0.57"), std::string::npos) << info->warnings[0];
  EXPECT_NE(info->warnings[0].find("energy gain"), std::string::npos);
  EXPECT_NE(info->warnings[0].find("missed"), std::string::npos);
}

TEST(TimeStep, FastParticlesWarnAboutStepsPerContact) {
  RunConfig c = validConfig(2);
  c.particles.velocity = {{0, 0, 0}, {50, 0, 0}};
  const auto info = chooseTimeStep(c);
  ASSERT_TRUE(info.isOk());
  ASSERT_EQ(info->warnings.size(), 1u);
  EXPECT_NE(info->warnings[0].find("steps of dt"), std::string::npos) << info->warnings[0];
}

TEST(TimeStep, NoParticles) {
  RunConfig c = validConfig(0);
  const auto automatic = chooseTimeStep(c);
  ASSERT_FALSE(automatic.isOk());
  EXPECT_EQ(automatic.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(automatic.status().message().find("set simulation.dt"), std::string::npos);
  c.sim.dt = 1e-5;
  const auto fixed = chooseTimeStep(c);
  ASSERT_TRUE(fixed.isOk());
  EXPECT_EQ(fixed->dt, 1e-5);
  EXPECT_EQ(fixed->rayleighTime, 0.0);
}

TEST(TimeStep, InvalidInputsAreErrorsNotGarbage) {
  RunConfig c = validConfig();
  c.particles.radius[1] = -1;
  EXPECT_FALSE(chooseTimeStep(c).isOk());
  c = validConfig();
  c.materials[0].youngsModulus = 0;
  EXPECT_FALSE(chooseTimeStep(c).isOk());
  c = validConfig();
  c.particles.material[0] = 4;
  EXPECT_FALSE(chooseTimeStep(c).isOk());
}

// simulation.rebuildInterval = N rebuilds the neighbour lists exactly every N steps, whatever the particles
// did; 0 (the default) rebuilds only when the skin criterion asks (here: never, the spheres barely move).
TEST(RebuildInterval, FixedIntervalRebuildsExactlyEveryNSteps) {
  for (const int every : {0, 1, 5}) {
    RunConfig c = validConfig();
    c.sim.rebuildInterval = every;
    c.sim.threads = 1;
    auto sim = Simulation::create(c);
    ASSERT_TRUE(sim.isOk()) << sim.status().toString();
    const std::int64_t atSetup = sim.value()->rebuilds();
    ASSERT_TRUE(sim.value()->runSteps(20).isOk());
    EXPECT_EQ(sim.value()->rebuilds() - atSetup, every == 0 ? 0 : 20 / every) << "every " << every;
  }
}

}  // namespace
}  // namespace pflow::compute
