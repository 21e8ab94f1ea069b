// frontend::loadScene / loadSceneFromString: the YAML scene format (docs/scene-format.md) -> compute::RunConfig.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <string>

#include "compute/dem/ModelChoice.h"
#include "compute/dem/contact/ContactParams.h"
#include "frontend/SceneLoader.h"

namespace pflow::frontend {
namespace {

using compute::MeshConfig;
using compute::RunConfig;

const char* kFullScene = R"(# every key of the minimal format
materials:
  - name: glass
    youngs_modulus: 4.8e10   # Pa
    poisson_ratio: 0.2
    density: 2800            # kg/m^3
    restitution: 0.9
    friction: 0.5
    rolling_friction: 0.01
  - name: steel
    youngs_modulus: 2.1e11
    poisson_ratio: 0.3
    density: 7800
    restitution: 0.7
    friction: 0.4
pairs:
  - materials: [glass, steel]
    restitution: 0.8
    friction: 0.3
particles:
  - material: steel
    list:
      - {position: [0.05, 0.05, 0.05], radius: 0.001, velocity: [0, 0, -1], angular_velocity: [0, 10, 0]}
      - position: [0.06, 0.05, 0.05]
        radius: 0.002
  - material: glass
    method: lattice
    region: {box: {min: [0.001, 0.001, 0.001], max: [0.011, 0.011, 0.011]}}
    size: 0.0005
    lattice: {spacing: 0.00105, jitter: 0.01}
    velocity: [0, 0, -0.5]
    count: 500
geometry:
  - plane: {point: [0, 0, 0], normal: [0, 0, 2]}
    name: floor
    material: glass
  - box: {min: [0, 0, 0], max: [0.1, 0.1, 0.1], open: [top]}
    material: steel
    name: bin
    motion: {velocity: [0.1, 0, 0], angular_velocity: 2.0, axis: [0, 0, 3], axis_point: [0.05, 0.05, 0], start_time: 0.01}
  - mesh:
      vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
      triangles: [[0, 1, 2], [1, 3, 2]]
      surfaces: [0, 1]
    material: glass
simulation:
  gravity: [0, 0, -9.81]
  duration: 0.1
  dt: auto
  dt_fraction: 0.15
  skin: 0.0001
  snapshot_interval: 0.01
  domain: {min: [-0.1, -0.1, -0.1], max: [1.1, 1.1, 0.5]}
  precision: float
  decomposition: multisection
  history_slots: 12
  wall_history_slots: 6
  threads: 2
  seed: 42
  reproducible: false
output:
  file: out.h5
)";

// One material (the benchmark's) plus the given particle sets, simulation body and geometry list.
std::string minimalScene(const std::string& particles, const std::string& simulation = "  duration: 0.1\n",
                         const std::string& geometry = "") {
  std::string s =
      "materials:\n"
      "  - name: glass\n"
      "    youngs_modulus: 1.0e7\n"
      "    poisson_ratio: 0.3\n"
      "    density: 2500\n"
      "    restitution: 0.5\n"
      "    friction: 0.5\n";
  if (!particles.empty()) s += "particles:\n" + particles;
  if (!geometry.empty()) s += "geometry:\n" + geometry;
  s += "simulation:\n" + simulation;
  return s;
}

std::string errorText(const Result<LoadedScene>& r) { return r.isOk() ? std::string("(loaded fine)") : r.status().message(); }

bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }

#define EXPECT_HAS(text, part) EXPECT_TRUE(contains(text, part)) << "want: " << (part) << "\ngot:\n" << (text)

// A lattice set in a box region: `extra` holds further set keys, 4-space indented.
std::string latticeSet(const std::string& box, const std::string& radius, const std::string& extra = "") {
  return "  - method: lattice\n    region: {box: " + box + "}\n    size: " + radius + "\n" + extra;
}
std::string latticeScene(const std::string& set, std::uint64_t seed = 1) {
  return minimalScene(set, "  duration: 0.1\n  seed: " + std::to_string(seed) + "\n");
}

// ---- a valid scene ------------------------------------------------------------------------------------------------

TEST(SceneLoader, FullSceneRoundTrip) {
  const auto r = loadSceneFromString(kFullScene, "full.yaml");
  ASSERT_TRUE(r.isOk()) << errorText(r);
  const RunConfig& c = r->config;
  EXPECT_EQ(r->sourcePath, "full.yaml");
  EXPECT_EQ(r->outputFile, "out.h5");

  ASSERT_EQ(c.materials.size(), 2u);
  EXPECT_EQ(c.materials[0].name, "glass");
  EXPECT_EQ(c.materials[0].youngsModulus, 4.8e10);
  EXPECT_EQ(c.materials[0].poissonRatio, 0.2);
  EXPECT_EQ(c.materials[0].density, 2800);
  EXPECT_EQ(c.materials[0].restitution, 0.9);
  EXPECT_EQ(c.materials[0].friction, 0.5);
  EXPECT_EQ(c.materials[0].rollingFriction, 0.01);
  EXPECT_EQ(c.materials[1].name, "steel");
  EXPECT_EQ(c.materials[1].rollingFriction, 0.0);  // default

  ASSERT_EQ(c.pairs.size(), 1u);
  EXPECT_EQ(c.pairs[0].a, 0);
  EXPECT_EQ(c.pairs[0].b, 1);
  EXPECT_EQ(c.pairs[0].restitution, 0.8);
  EXPECT_EQ(c.pairs[0].friction, 0.3);
  EXPECT_FALSE(c.pairs[0].rollingFriction.has_value());

  const auto& p = c.particles;
  ASSERT_EQ(p.size(), 502u);
  ASSERT_EQ(p.radius.size(), 502u);
  ASSERT_EQ(p.material.size(), 502u);
  ASSERT_EQ(p.velocity.size(), 502u);
  ASSERT_EQ(p.angularVelocity.size(), 502u);
  EXPECT_EQ(p.position[0].x, 0.05);
  EXPECT_EQ(p.radius[0], 0.001);
  EXPECT_EQ(p.material[0], 1);
  EXPECT_EQ(p.velocity[0].z, -1.0);
  EXPECT_EQ(p.angularVelocity[0].y, 10.0);
  EXPECT_EQ(p.radius[1], 0.002);
  EXPECT_EQ(p.velocity[1].z, 0.0);
  for (std::size_t i = 2; i < p.size(); ++i) {
    EXPECT_EQ(p.radius[i], 0.0005);
    EXPECT_EQ(p.material[i], 0);
    EXPECT_EQ(p.velocity[i].z, -0.5);
    EXPECT_EQ(p.angularVelocity[i].y, 0.0);
  }

  ASSERT_EQ(c.planes.size(), 1u);
  EXPECT_EQ(c.planes[0].name, "floor");
  EXPECT_EQ(c.planes[0].material, 0);
  EXPECT_EQ(c.planes[0].normal.z, 1.0);  // normalised

  ASSERT_EQ(c.meshes.size(), 2u);
  const MeshConfig& bin = c.meshes[0];
  EXPECT_EQ(bin.name, "bin");
  EXPECT_EQ(bin.material, 1);
  EXPECT_EQ(bin.triangles.size(), 10u);
  EXPECT_EQ(bin.motion.velocity.x, 0.1);
  EXPECT_EQ(bin.motion.angularSpeed, 2.0);
  EXPECT_EQ(bin.motion.axis.z, 1.0);  // normalised
  EXPECT_EQ(bin.motion.axisPoint.x, 0.05);
  EXPECT_EQ(bin.motion.startTime, 0.01);
  const MeshConfig& sheet = c.meshes[1];
  EXPECT_EQ(sheet.name, "mesh2");  // default name: kind + geometry index
  EXPECT_EQ(sheet.vertices.size(), 4u);
  ASSERT_EQ(sheet.triangles.size(), 2u);
  EXPECT_EQ(sheet.triangles[1][1], 3u);
  // Scene-wide surface numbers: the plane is 0, the box's six faces 1..6 (open ones keep their number), the sheet's
  // local surfaces 0 and 1 become 7 and 8.
  EXPECT_EQ(sheet.surface, (std::vector<std::int32_t>{7, 8}));
  EXPECT_EQ(c.planes[0].surface, 0);
  ASSERT_EQ(c.surfaceNames.size(), 9u);
  EXPECT_EQ(c.surfaceNames[0], "floor");
  EXPECT_EQ(c.surfaceNames[1], "bin/bottom");
  EXPECT_EQ(c.surfaceNames[6], "bin/back");
  EXPECT_EQ(c.surfaceNames[7], "mesh2/surface0");
  ASSERT_EQ(r.value().surfaces.size(), 9u);
  EXPECT_EQ(r.value().surfaces[1].wall, "bin");
  EXPECT_FALSE(sheet.motion.moves());

  const auto& s = c.sim;
  EXPECT_EQ(s.gravity.z, -9.81);
  EXPECT_EQ(s.duration, 0.1);
  EXPECT_FALSE(s.dt.has_value());
  EXPECT_EQ(s.dtFraction, 0.15);
  EXPECT_EQ(s.skin, 0.0001);
  EXPECT_EQ(s.snapshotInterval, 0.01);
  ASSERT_TRUE(s.domain.has_value());
  EXPECT_EQ(s.domain->hi.z, 0.5);
  EXPECT_EQ(s.precision, compute::Precision::kFloat);
  EXPECT_EQ(s.decomposition, compute::DecompositionKind::kMultiSection);
  EXPECT_EQ(s.historySlots, 12);
  EXPECT_EQ(s.wallHistorySlots, 6);
  EXPECT_EQ(s.threads, 2);
  EXPECT_EQ(s.seed, 42u);
  EXPECT_FALSE(s.reproducible);
}

TEST(SceneLoader, DefaultsOfAMinimalScene) {
  const auto r = loadSceneFromString(minimalScene("  - list:\n      - {position: [0, 0, 0.01], radius: 0.001}\n"));
  ASSERT_TRUE(r.isOk()) << errorText(r);
  const RunConfig& c = r->config;
  EXPECT_EQ(c.materials[0].rollingFriction, 0.0);
  EXPECT_EQ(c.particles.material[0], 0);  // the only material
  EXPECT_TRUE(c.particles.velocity.empty());  // all at rest
  EXPECT_TRUE(c.particles.angularVelocity.empty());
  EXPECT_FALSE(c.sim.dt.has_value());
  EXPECT_EQ(c.sim.dtFraction, 0.2);
  EXPECT_LT(c.sim.skin, 0);
  EXPECT_EQ(c.sim.gravity.z, -9.81);
  EXPECT_EQ(c.sim.historySlots, 8);
  EXPECT_EQ(c.sim.wallHistorySlots, 1);
  EXPECT_EQ(c.sim.precision, compute::Precision::kDouble);
  EXPECT_EQ(c.sim.decomposition, compute::DecompositionKind::kSfc);
  EXPECT_EQ(c.sim.seed, 1u);
  EXPECT_TRUE(c.sim.reproducible);
  EXPECT_TRUE(r->outputFile.empty());

  const auto fixed = loadSceneFromString(minimalScene("", "  duration: 0.1\n  dt: 1.0e-6\n  skin: auto\n"));
  ASSERT_TRUE(fixed.isOk()) << errorText(fixed);
  EXPECT_EQ(fixed->config.sim.dt, 1.0e-6);
}

TEST(SceneLoader, AFixedMaterial) {
  std::string text = minimalScene("  - list:\n      - {position: [0, 0, 0.01], radius: 0.001}\n");
  text.replace(text.find("    friction: 0.5\n"), 18, "    friction: 0.5\n    fixed: true\n");
  const auto r = loadSceneFromString(text);
  ASSERT_TRUE(r.isOk()) << errorText(r);
  EXPECT_TRUE(r->config.materials[0].fixed);
  EXPECT_FALSE(loadSceneFromString(minimalScene("  - list:\n      - {position: [0, 0, 0.01], radius: 0.001}\n"))->config.materials[0].fixed);
}

TEST(SceneLoader, ReadsFilesAndReportsMissingOnes) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "pflow_scene_loader_test.yaml";
  {
    std::ofstream out(file);
    out << kFullScene;
  }
  const auto r = loadScene(file.string());
  ASSERT_TRUE(r.isOk()) << errorText(r);
  EXPECT_EQ(r->sourcePath, file.string());
  std::filesystem::remove(file);

  const auto missing = loadScene("/nonexistent/dir/scene.yaml");
  ASSERT_FALSE(missing.isOk());
  EXPECT_EQ(missing.status().code(), StatusCode::kIo);
  EXPECT_HAS(missing.status().message(), "/nonexistent/dir/scene.yaml");
}

TEST(SceneLoader, TheDocumentedExampleLoads) {
  // Tests run in the source directory (pflow_add_test); keeps docs/scene-format.md honest.
  std::ifstream in("docs/scene-format.md");
  ASSERT_TRUE(in) << "run from the repository root";
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto section = doc.find("## A complete example");
  ASSERT_NE(section, std::string::npos);
  const auto begin = doc.find("```yaml\n", section);
  ASSERT_NE(begin, std::string::npos);
  const auto end = doc.find("```", begin + 8);
  const auto r = loadSceneFromString(doc.substr(begin + 8, end - begin - 8), "scene-format.md");
  ASSERT_TRUE(r.isOk()) << errorText(r);
  EXPECT_EQ(r->config.particles.size(), 19u * 19u * 19u);  // (20 mm - 1 mm) / 1.05 mm -> 19 sites per axis
  EXPECT_EQ(r->config.meshes[0].triangles.size(), 10u);
  EXPECT_EQ(r->outputFile, "settle.h5");
}

// ---- errors -------------------------------------------------------------------------------------------------------

TEST(SceneLoader, ReportsSeveralErrorsTogetherWithLinesAndPaths) {
  const char* yaml = R"(materials:
  - name: glass
    youngs_modulus: abc
    poisson_ratio: 0.7
    density: 2800
    restitution: 0.9
    friction: 0.5
    colour: blue
particles:
  - material: glas
    list:
      - {position: [0, 0, 0.01], radius: 0.001}
simulation:
  duration: 0.1
  dt: -1
)";
  const auto r = loadSceneFromString(yaml, "bad.yaml");
  ASSERT_FALSE(r.isOk());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  const std::string m = r.status().message();
  EXPECT_HAS(m, "bad.yaml: 5 error(s)");
  EXPECT_HAS(m, "line 3, column 21: materials[0].youngs_modulus: expected a number, got 'abc'");
  EXPECT_HAS(m, "line 8, column 5: materials[0].colour: unknown key 'colour'");
  EXPECT_HAS(m, "line 10, column 15: particles[0].material: unknown material 'glas'; did you mean 'glass'?");
  // From RunConfig::validate(), mapped back to the file.
  EXPECT_HAS(m, "line 4, column 20: materials[0].poisson_ratio: 0.7 is outside (-1, 0.5)");
  EXPECT_HAS(m, "line 15, column 7: simulation.dt: -1 must be > 0");
  // No follow-on noise about the unusable modulus or material index.
  EXPECT_FALSE(contains(m, "must be > 0\nline")) << m;
  EXPECT_FALSE(contains(m, "is not a material index")) << m;
}

TEST(SceneLoader, UnknownKeySuggestsTheClosestValidKey) {
  const std::string yaml =
      "materials:\n"
      "  - name: glass\n"
      "    youngs_modulis: 1.0e7\n"
      "    poisson_ratio: 0.3\n"
      "    density: 2500\n"
      "    restitution: 0.5\n"
      "    friction: 0.5\n"
      "simulation: {duration: 0.1, snapshot_intervall: 0.01}\n";
  const auto r = loadSceneFromString(yaml);
  ASSERT_FALSE(r.isOk());
  const std::string m = r.status().message();
  EXPECT_HAS(m, "line 3, column 5: materials[0].youngs_modulis: unknown key 'youngs_modulis'; did you mean 'youngs_modulus'? "
                "Valid keys here: name, youngs_modulus, poisson_ratio, density, restitution, friction, rolling_friction");
  EXPECT_HAS(m, "materials[0].youngs_modulus: required key 'youngs_modulus' is missing");
  EXPECT_HAS(m, "line 8, column 29: simulation.snapshot_intervall: unknown key 'snapshot_intervall'; did you mean 'snapshot_interval'?");

  const auto top = loadSceneFromString(minimalScene("") + "geometery: []\n");
  ASSERT_FALSE(top.isOk());
  EXPECT_HAS(top.status().message(), "unknown key 'geometery'; did you mean 'geometry'?");
}

TEST(SceneLoader, WrongTypesAreErrors) {
  const auto r = loadSceneFromString(minimalScene("  - list:\n"
                                                  "      - {position: [0, 0], radius: \"0.001\"}\n"
                                                  "      - {position: 5, radius: [1]}\n"
                                                  "      - {position: [0, x, 0.1], radius: 0.001}\n",
                                                  "  duration: 0.1s\n  history_slots: 2.5\n  dt: fast\n  precision: duble\n  decomposition: morton\n"
                                                  "  reproducible: maybe\n"));
  ASSERT_FALSE(r.isOk());
  const std::string m = r.status().message();
  EXPECT_HAS(m, "particles[0].list[0].position: expected a list of 3 numbers [x, y, z], got a list of 2 items");
  EXPECT_HAS(m, "particles[0].list[0].radius: expected a number, got the quoted string '0.001' (write numbers without quotes)");
  EXPECT_HAS(m, "particles[0].list[1].position: expected a list of 3 numbers [x, y, z], got '5'");
  EXPECT_HAS(m, "particles[0].list[1].radius: expected a number, got a list of 1 item");
  EXPECT_HAS(m, "particles[0].list[2].position: component 1 of [x, y, z]: expected a number, got 'x'");
  EXPECT_HAS(m, "simulation.duration: expected a number, got '0.1s'");
  EXPECT_HAS(m, "simulation.history_slots: expected an integer, got '2.5'");
  EXPECT_HAS(m, "simulation.dt: expected a number (s) or 'auto', got 'fast'");
  EXPECT_HAS(m, "simulation.precision: unknown precision 'duble'; did you mean 'double'?");
  EXPECT_HAS(m, "simulation.decomposition: unknown decomposition 'morton'");
  EXPECT_HAS(m, "simulation.reproducible: expected true or false, got 'maybe'");
  // Placeholders for broken values do not produce validate() noise (e.g. radius 0 "must be > 0").
  EXPECT_FALSE(contains(m, "must be > 0")) << m;
  EXPECT_HAS(m, "11 error(s)");
}

TEST(SceneLoader, StructuralErrors) {
  const auto syntax = loadSceneFromString("materials:\n  - name: [glass\nsimulation: {}\n", "s.yaml");
  ASSERT_FALSE(syntax.isOk());
  EXPECT_HAS(syntax.status().message(), "YAML syntax error");
  EXPECT_HAS(syntax.status().message(), "line ");

  const auto empty = loadSceneFromString("# nothing here\n");
  ASSERT_FALSE(empty.isOk());
  EXPECT_HAS(empty.status().message(), "the scene is empty");

  const auto noSections = loadSceneFromString("output: {file: a.h5}\n");
  ASSERT_FALSE(noSections.isOk());
  EXPECT_HAS(noSections.status().message(), "materials: required key 'materials' is missing");
  EXPECT_HAS(noSections.status().message(), "simulation: required key 'simulation' is missing");

  const auto duplicate = loadSceneFromString(minimalScene("", "  duration: 0.1\n  duration: 0.2\n"));
  ASSERT_FALSE(duplicate.isOk());
  EXPECT_HAS(duplicate.status().message(), "line 10, column 3: simulation.duration: duplicate key 'duration' (first given at line 9)");

  const auto both = loadSceneFromString(minimalScene("  - list: []\n    lattice: {}\n"));
  ASSERT_FALSE(both.isOk());
  EXPECT_HAS(both.status().message(), "particles[0].lattice: 'lattice' options apply to method lattice, and this set's method is list");

  const auto notAList = loadSceneFromString(minimalScene("  material: glass\n"));
  ASSERT_FALSE(notAList.isOk());
  EXPECT_HAS(notAList.status().message(), "particles: expected a list of particle sets");
}

TEST(SceneLoader, MaterialIsRequiredWhenThereAreSeveral) {
  std::string yaml = minimalScene("  - list:\n      - {position: [0, 0, 0.01], radius: 0.001}\n");
  yaml.insert(yaml.find("particles:"), "  - name: steel\n    youngs_modulus: 2e11\n    poisson_ratio: 0.3\n    density: 7800\n"
                                       "    restitution: 0.5\n    friction: 0.5\n");
  const auto r = loadSceneFromString(yaml);
  ASSERT_FALSE(r.isOk());
  EXPECT_HAS(r.status().message(), "particles[0].material: required key 'material' is missing (one of: glass, steel)");
}

TEST(SceneLoader, BrokenPlaneAddsNoFollowOnErrors) {
  const auto r = loadSceneFromString(minimalScene("  - list:\n      - {position: [0, 0, 0.01], radius: 0.001}\n", "  duration: 0.1\n",
                                                  "  - plane: {point: [0, 0, 1], normal: up}\n"));
  ASSERT_FALSE(r.isOk());
  EXPECT_HAS(r.status().message(), "1 error(s)");
  EXPECT_HAS(r.status().message(), "geometry[0].plane.normal: expected a list of 3 numbers [x, y, z], got 'up'");
}

// ---- RunConfig::validate() through the loader: each bad input class, located in the file -------------------------

TEST(SceneLoader, ValidateFindingsAreMappedToTheFile) {
  const std::string particles =
      "  - list:\n"
      "      - {position: [0, 0, 0.01], radius: -0.001}\n"    // line 10
      "      - {position: [0, 0, -0.01], radius: 0.001}\n"    // line 11: behind the floor
      "      - {position: [.nan, 0, 0.01], radius: 0.001}\n"  // line 12: NaN
      "      - {position: [0, 0, 0.0005], radius: 0.001}\n";  // line 13: 50 % overlap
  const std::string geometry = "  - plane: {point: [0, 0, 0], normal: [0, 0, 1]}\n    name: floor\n";
  std::string yaml = minimalScene(particles, "  duration: 0.1\n  dt: 0\n", geometry);
  yaml.replace(yaml.find("youngs_modulus: 1.0e7"), 21, "youngs_modulus: -1.0e7");
  yaml.replace(yaml.find("poisson_ratio: 0.3"), 18, "poisson_ratio: 0.5");
  yaml.replace(yaml.find("restitution: 0.5"), 16, "restitution: 1.2");
  const auto r = loadSceneFromString(yaml);
  ASSERT_FALSE(r.isOk());
  const std::string m = r.status().message();
  EXPECT_HAS(m, "line 3, column 21: materials[0].youngs_modulus: -1e+07 must be > 0");
  EXPECT_HAS(m, "line 4, column 20: materials[0].poisson_ratio: 0.5 is outside (-1, 0.5)");
  EXPECT_HAS(m, "line 6, column 18: materials[0].restitution: 1.2 is outside (0, 1]");
  EXPECT_HAS(m, "line 10, column 42: particles[0].list[0].radius: -0.001 must be > 0");
  EXPECT_HAS(m, "line 11, column 20: particles[0].list[1].position: centre [0, 0, -0.01] lies behind plane 'floor' (planes[0]) by 0.01 m");
  EXPECT_HAS(m, "line 12, column 20: particles[0].list[2].position: [nan, 0, 0.01] is not finite");
  EXPECT_HAS(m, "particles[0].list[3].position: starts overlapping plane 'floor' (planes[0]) by 0.0005 m (50% of its radius");
  EXPECT_HAS(m, "simulation.dt: 0 must be > 0");
}

TEST(SceneLoader, LatticeParticleFindingsNameTheLattice) {
  // Generated particles keep clear of walls; a domain that cuts the region is reported per particle.
  const std::string yaml = minimalScene(latticeSet("{min: [0, 0, -0.001], max: [0.002, 0.002, 0.002]}", "0.0005"),
                                        "  duration: 0.1\n  domain: {min: [0, 0, 0.0009], max: [1, 1, 1]}\n",
                                        "  - plane: {point: [0, 0, 0], normal: [0, 0, 1]}\n");
  const auto r = loadSceneFromString(yaml);
  ASSERT_FALSE(r.isOk());
  EXPECT_HAS(r.status().message(), "line 10, column 13: particles[0].region: particle 0 of this set (particles.position[0]): centre");
}

// ---- lattice ------------------------------------------------------------------------------------------------------

TEST(SceneLoader, LatticeFillsTheBoxWithinBoundsAndJitter) {
  const double r = 0.0005, spacing = 0.00105, jitter = 0.02;
  const auto loaded = loadSceneFromString(latticeScene(latticeSet("{min: [0, 0, 0], max: [0.01, 0.005, 0.003]}", "0.0005",
                                                                  "    lattice: {spacing: 0.00105, jitter: 0.02}\n")));
  ASSERT_TRUE(loaded.isOk()) << errorText(loaded);
  const auto& p = loaded->config.particles;
  // Sites per axis: floor((L - 2r) / s) + 1 = 9, 4, 2.
  ASSERT_EQ(p.size(), 9u * 4u * 2u);
  std::set<std::tuple<long, long, long>> sites;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec3d x = p.position[i];
    EXPECT_GE(x.x - r, 0.0);
    EXPECT_LE(x.x + r, 0.01);
    EXPECT_GE(x.y - r, 0.0);
    EXPECT_LE(x.y + r, 0.005);
    EXPECT_GE(x.z - r, 0.0);
    EXPECT_LE(x.z + r, 0.003);
    // Nearest site, and the displacement from it within [-jitter * r, jitter * r] per axis.
    const long ix = std::lround((x.x - r) / spacing), iy = std::lround((x.y - r) / spacing), iz = std::lround((x.z - r) / spacing);
    sites.insert({ix, iy, iz});
    EXPECT_LE(std::fabs(x.x - (r + ix * spacing)), jitter * r * (1 + 1e-9));
    EXPECT_LE(std::fabs(x.y - (r + iy * spacing)), jitter * r * (1 + 1e-9));
    EXPECT_LE(std::fabs(x.z - (r + iz * spacing)), jitter * r * (1 + 1e-9));
    EXPECT_EQ(p.radius[i], r);
  }
  EXPECT_EQ(sites.size(), p.size());  // one particle per site
  // Jitter happened (not all exactly on their sites).
  EXPECT_NE(p.position[1].x - p.position[0].x, spacing);
}

TEST(SceneLoader, LatticeCountCapFillsLowestLayersFirst) {
  const auto loaded = loadSceneFromString(latticeScene(latticeSet("{min: [0, 0, 0], max: [0.01, 0.01, 0.01]}", "0.0005", "    count: 100\n")));
  ASSERT_TRUE(loaded.isOk()) << errorText(loaded);
  const auto& p = loaded->config.particles;
  ASSERT_EQ(p.size(), 100u);
  // Default spacing 2.1 r = 1.05 mm -> 9 x 9 = 81 per layer: particles 0..80 in the bottom layer.
  EXPECT_NEAR(p.position[80].z, 0.0005, 0.005 * 0.0005 * 1.0001);
  EXPECT_NEAR(p.position[81].z, 0.0005 + 0.00105, 0.005 * 0.0005 * 1.0001);

  const auto tooMany = loadSceneFromString(latticeScene(latticeSet("{min: [0, 0, 0], max: [0.01, 0.01, 0.01]}", "0.0005", "    count: 1000\n")));
  ASSERT_FALSE(tooMany.isOk());
  EXPECT_HAS(tooMany.status().message(), "particles[0]: lattice: count 1000 is more than the 729 lattice particles that fit");
}

TEST(SceneLoader, LatticeIsDeterministicPerSeedAndSet) {
  const std::string lattice = latticeSet("{min: [0, 0, 0], max: [0.005, 0.005, 0.005]}", "0.0005", "    lattice: {jitter: 0.04}\n");
  const auto a = loadSceneFromString(latticeScene(lattice, 7));
  const auto b = loadSceneFromString(latticeScene(lattice, 7));
  const auto c = loadSceneFromString(latticeScene(lattice, 8));
  ASSERT_TRUE(a.isOk() && b.isOk() && c.isOk()) << errorText(a);
  const auto& pa = a->config.particles.position;
  const auto& pb = b->config.particles.position;
  const auto& pc = c->config.particles.position;
  ASSERT_EQ(pa.size(), pb.size());
  bool differs = false;
  for (std::size_t i = 0; i < pa.size(); ++i) {
    EXPECT_EQ(pa[i].x, pb[i].x);
    EXPECT_EQ(pa[i].y, pb[i].y);
    EXPECT_EQ(pa[i].z, pb[i].z);
    differs |= pa[i].x != pc[i].x;
  }
  EXPECT_TRUE(differs) << "another seed gives another jitter";

  // Two identical sets in one scene get different jitter (the set index is part of the seed).
  // The second set fills the same region as the first, which leaves no room: put it beside.
  const std::string beside = latticeSet("{min: [0.01, 0, 0], max: [0.015, 0.005, 0.005]}", "0.0005", "    lattice: {jitter: 0.04}\n");
  const auto twoSets = loadSceneFromString(minimalScene(lattice + beside));
  ASSERT_TRUE(twoSets.isOk()) << errorText(twoSets);
  const auto& p2 = twoSets->config.particles.position;
  ASSERT_EQ(p2.size(), 2 * pa.size());
  // Jitter of the first particle of each set, measured from its site: different draws differ by far more than
  // the rounding of the two offsets (~1e-18 m).
  EXPECT_GT(std::fabs((p2[0].x - 0.0005) - (p2[pa.size()].x - 0.0105)), 1e-12);
}

TEST(SceneLoader, LatticeParameterErrors) {
  const auto r = loadSceneFromString(latticeScene(latticeSet("{min: [0, 0, 0], max: [0.01, 0.01, 0.01]}", "0.0005",
                                                             "    lattice: {spacing: 0.00105, jitter: 0.1}\n")));
  ASSERT_FALSE(r.isOk());
  EXPECT_HAS(r.status().message(), "particles[0].lattice.jitter: 0.1 lets neighbouring particles overlap: with spacing 0.00105 and "
                                   "largest radius 0.0005 it must be <= 0.05");

  const auto tight = loadSceneFromString(latticeScene(latticeSet("{min: [0, 0, 0], max: [0.01, 0.01, 0.01]}", "0.0005", "    lattice: {spacing: 0.0009}\n")));
  ASSERT_FALSE(tight.isOk());
  EXPECT_HAS(tight.status().message(), "particles[0].lattice.spacing: 0.0009 must be >= the largest diameter 0.001");

  const auto inverted = loadSceneFromString(latticeScene(latticeSet("{min: [0, 0, 0], max: [0.01, -0.01, 0.01]}", "-1")));
  ASSERT_FALSE(inverted.isOk());
  EXPECT_HAS(inverted.status().message(), "particles[0].region.box: max [0.01, -0.01, 0.01] must be > min [0, 0, 0] on every axis");
  EXPECT_HAS(inverted.status().message(), "particles[0].size: -1 must be > 0");
}

// ---- box and inline meshes ----------------------------------------------------------------------------------------

Vec3d triangleNormal(const MeshConfig& m, std::size_t t) {
  const Vec3d a = m.vertices[m.triangles[t][0]], b = m.vertices[m.triangles[t][1]], c = m.vertices[m.triangles[t][2]];
  return cross(b - a, c - a);
}

TEST(SceneLoader, BoxNormalsPointInwardAndOpenFacesAreOmitted) {
  const auto r = loadSceneFromString(minimalScene("", "  duration: 0.1\n",
                                                  "  - box: {min: [0, 0, 0], max: [0.1, 0.2, 0.3], open: [top, front]}\n"));
  ASSERT_TRUE(r.isOk()) << errorText(r);
  ASSERT_EQ(r->config.meshes.size(), 1u);
  const MeshConfig& m = r->config.meshes[0];
  ASSERT_EQ(m.triangles.size(), 8u);  // 4 faces x 2
  ASSERT_EQ(m.surface.size(), 8u);
  const Vec3d centre{0.05, 0.1, 0.15};
  std::map<int, double> areaPerSurface;
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const Vec3d n = triangleNormal(m, t);
    const Vec3d a = m.vertices[m.triangles[t][0]];
    EXPECT_GT(dot(n, centre - a), 0) << "triangle " << t << " faces away from the box centre";
    areaPerSurface[m.surface[t]] += 0.5 * norm(n);
  }
  // Surfaces: bottom 0, left 2, right 3, back 5 (top 1 and front 4 open); numbering stays per face name.
  ASSERT_EQ(areaPerSurface.size(), 4u);
  EXPECT_NEAR(areaPerSurface[0], 0.1 * 0.2, 1e-12);
  EXPECT_NEAR(areaPerSurface[2], 0.2 * 0.3, 1e-12);
  EXPECT_NEAR(areaPerSurface[3], 0.2 * 0.3, 1e-12);
  EXPECT_NEAR(areaPerSurface[5], 0.1 * 0.3, 1e-12);
  EXPECT_EQ(areaPerSurface.count(1), 0u);
  EXPECT_EQ(areaPerSurface.count(4), 0u);
}

TEST(SceneLoader, BoxResolutionSubdividesEveryFace) {
  const double resolution = 0.03;
  const auto r = loadSceneFromString(minimalScene("", "  duration: 0.1\n",
                                                  "  - box: {min: [0, 0, 0], max: [0.1, 0.1, 0.05], resolution: 0.03}\n"));
  ASSERT_TRUE(r.isOk()) << errorText(r);
  const MeshConfig& m = r->config.meshes[0];
  EXPECT_GT(m.triangles.size(), 12u);
  double area = 0;
  const Vec3d centre{0.05, 0.05, 0.025};
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    for (int k = 0; k < 3; ++k) EXPECT_LE(norm(m.vertices[tri[(k + 1) % 3]] - m.vertices[tri[k]]), resolution * (1 + 1e-12));
    EXPECT_GT(dot(triangleNormal(m, t), centre - m.vertices[tri[0]]), 0);
    area += 0.5 * norm(triangleNormal(m, t));
  }
  EXPECT_NEAR(area, 2 * (0.1 * 0.1 + 0.1 * 0.05 + 0.1 * 0.05), 1e-12);
}

TEST(SceneLoader, BoxAndMeshErrors) {
  const auto r = loadSceneFromString(minimalScene("", "  duration: 0.1\n",
                                                  "  - box: {min: [0, 0, 0], max: [1, 1, 1], open: [top, rigth]}\n"
                                                  "  - mesh:\n"
                                                  "      vertices: [[0, 0, 0], [1, 0, 0], [2, 0, 0]]\n"
                                                  "      triangles: [[0, 1, 2], [0, 1, 5], [0, -1, 2]]\n"
                                                  "    motion: {angular_velocity: 1.0, axis: [0, 0, 0]}\n"
                                                  "  - plane: {point: [0, 0, 0], normal: [0, 0, 1]}\n"
                                                  "    motion: {velocity: [1, 0, 0]}\n"));
  ASSERT_FALSE(r.isOk());
  const std::string m = r.status().message();
  EXPECT_HAS(m, "geometry[0].box.open[1]: unknown face 'rigth'; did you mean 'right'? Choices: bottom, top, left, right, front, back");
  EXPECT_HAS(m, "line 12, column 19: geometry[1].mesh.triangles[0]: triangle [0, 1, 2] is degenerate (zero area)");
  EXPECT_HAS(m, "geometry[1].mesh.triangles[1]: triangle [0, 1, 5] refers to a vertex outside [0, 3)");
  EXPECT_HAS(m, "geometry[1].mesh.triangles[2]: corner 1: expected a vertex index >= 0, got '-1'");
  EXPECT_HAS(m, "geometry[1].motion.axis: [0, 0, 0] is not a direction");
  EXPECT_HAS(m, "geometry[2].motion: planes cannot move");
}

}  // namespace
}  // namespace pflow::frontend

namespace pflow::frontend {
namespace {
TEST(SceneLoader, PhysicsSwitchesZeroTheCoefficients) {
  const std::string yaml =
      "materials:\n  - {name: a, youngs_modulus: 1e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5, rolling_friction: 0.1}\n"
      "pairs:\n  - {materials: [a, a], friction: 0.3, rolling_friction: 0.2}\n"
      "simulation: {duration: 0.1, physics: {friction: false, rolling_resistance: false}}\n";
  const auto r = loadSceneFromString(yaml);
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->config.materials[0].friction, 0.0);
  EXPECT_EQ(r->config.materials[0].rollingFriction, 0.0);
  EXPECT_EQ(*r->config.pairs[0].friction, 0.0);
  EXPECT_EQ(*r->config.pairs[0].rollingFriction, 0.0);
  const auto typo = loadSceneFromString("materials:\n  - {name: a, youngs_modulus: 1e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5}\n"
                                        "simulation: {duration: 0.1, physics: {rolling: false}}\n");
  ASSERT_FALSE(typo.isOk());
  EXPECT_NE(typo.status().message().find("simulation.physics.rolling: unknown key 'rolling'"), std::string::npos) << typo.status().message();
}

TEST(SceneLoader, AdhesionPerPairAndItsSwitch) {
  const std::string yaml =
      "materials:\n  - {name: a, youngs_modulus: 1e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5}\n"
      "  - {name: b, youngs_modulus: 1e8, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5}\n"
      "pairs:\n  - {materials: [a, a], cohesion: {model: jkr, work_of_adhesion: 0.05}}\n"
      "  - {materials: [a, b], cohesion: {model: constant, work_of_adhesion: 0.02}}\n";
  const auto r = loadSceneFromString(yaml + "simulation: {duration: 0.1}\n");
  ASSERT_TRUE(r.isOk()) << r.status().message();
  ASSERT_EQ(r->config.pairs.size(), 2u);
  EXPECT_EQ(r->config.pairs[0].cohesion, compute::CohesionModel::kJkr);
  EXPECT_EQ(r->config.pairs[0].workOfAdhesion, 0.05);
  EXPECT_EQ(r->config.pairs[1].cohesion, compute::CohesionModel::kConstant);
  const auto table = compute::buildContactTable(r->config.materials, r->config.pairs);
  EXPECT_EQ(table[0].cohesion, 1);  // a-a
  EXPECT_EQ(table[1].cohesion, 2);  // a-b
  EXPECT_EQ(table[2].cohesion, 2);  // b-a
  EXPECT_EQ(table[3].cohesion, 0);  // b-b: no pair asked
  EXPECT_NE(compute::deriveModel(r->config).text().find("adhesion: on"), std::string::npos);
  const auto off = loadSceneFromString(yaml + "simulation: {duration: 0.1, physics: {cohesion: false}}\n");
  ASSERT_TRUE(off.isOk()) << off.status().message();
  EXPECT_EQ(off->config.pairs[0].cohesion, compute::CohesionModel::kNone);
  EXPECT_NE(compute::deriveModel(off->config).text().find("adhesion: off"), std::string::npos);
}

// ---- output: the DEM run's time series ------------------------------------------------------------------------------

TEST(SceneLoader, SeriesIntervalAndFlowPlanes) {
  const std::string set = latticeSet("{min: [0, 0, 0], max: [0.01, 0.01, 0.01]}", "0.001");
  const auto ok = loadSceneFromString(latticeScene(set) + "output:\n  series_interval: 0.002\n  flow_planes:\n"
                                      "    - {name: outlet, point: [0, 0, -0.01], normal: [0, 0, -2]}\n");
  ASSERT_TRUE(ok.isOk()) << errorText(ok);
  EXPECT_DOUBLE_EQ(ok->config.series.interval, 0.002);
  ASSERT_EQ(ok->config.series.flowPlanes.size(), 1u);
  EXPECT_EQ(ok->config.series.flowPlanes[0].name, "outlet");
  EXPECT_DOUBLE_EQ(ok->config.series.flowPlanes[0].normal.z, -1.0);  // normalised

  const auto bad = loadSceneFromString(latticeScene(set) + "output:\n  series_interval: -1\n  flow_planes:\n"
                                       "    - {name: a b, point: [0, 0, 0], normal: [0, 0, 1]}\n"
                                       "    - {name: c, point: [0, 0, 0], normal: [0, 0, 0]}\n"
                                       "    - {name: c, point: [0, 0, 0], normal: [1, 0, 0]}\n"
                                       "    - {name: d, normal: [1, 0, 0]}\n");
  const std::string e = errorText(bad);
  EXPECT_HAS(e, "output.series_interval");
  EXPECT_HAS(e, "output.flow_planes[0].name");
  EXPECT_HAS(e, "output.flow_planes[1].normal");
  EXPECT_HAS(e, "'c' names another flow plane too");
  EXPECT_HAS(e, "output.flow_planes[3].point");
}

// motion.vibration: a shaker's amplitude, frequency and phase; an amplitude without a frequency is an error.
TEST(SceneLoader, WallVibration) {
  const std::string set = latticeSet("{min: [0, 0, 0.002], max: [0.01, 0.01, 0.01]}", "0.001");
  const std::string box = "  - box: {min: [-0.001, -0.001, 0], max: [0.011, 0.011, 0.02]}\n    name: pan\n";
  const auto ok = loadSceneFromString(minimalScene(set, "  duration: 0.1\n", box + "    motion: {vibration: {amplitude: [0, 0, 0.001], frequency: 50, phase: 0.5}}\n"));
  ASSERT_TRUE(ok.isOk()) << errorText(ok);
  ASSERT_EQ(ok->config.meshes.size(), 1u);
  const auto& m = ok->config.meshes[0].motion;
  EXPECT_DOUBLE_EQ(m.vibration.z, 0.001);
  EXPECT_DOUBLE_EQ(m.frequency, 50);
  EXPECT_DOUBLE_EQ(m.phase, 0.5);
  EXPECT_TRUE(m.moves());
  const auto bad = loadSceneFromString(minimalScene(set, "  duration: 0.1\n", box + "    motion: {vibration: {amplitude: [0, 0, 0.001], frequency: -1, tempo: 3}}\n"));
  const std::string e = errorText(bad);
  EXPECT_HAS(e, "vibration.frequency");
  EXPECT_HAS(e, "tempo");
  const auto profile = loadSceneFromString(minimalScene(set, "  duration: 0.1\n", box + "    motion: {velocity_profile: [[0, 0, 0, 0], [0.1, 0, 0, 0.05]]}\n"));
  ASSERT_TRUE(profile.isOk()) << errorText(profile);
  ASSERT_EQ(profile->config.meshes[0].motion.profile.size(), 2u);
  EXPECT_DOUBLE_EQ(profile->config.meshes[0].motion.profile[1].velocity.z, 0.05);
  const auto backwards = loadSceneFromString(minimalScene(set, "  duration: 0.1\n", box + "    motion: {velocity: [0, 0, 1], velocity_profile: [[0.2, 0, 0, 0], [0.1, 0, 0, 0.05], [1, 2]]}\n"));
  const std::string b = errorText(backwards);
  EXPECT_HAS(b, "velocity_profile[1]");
  EXPECT_HAS(b, "velocity_profile[2]");
  EXPECT_HAS(b, "not both");
}

// motion.drive: a press with a force limit and a motor with a torque limit load; each way of getting a drive wrong is
// named at its key.
TEST(SceneLoader, WallDrive) {
  const std::string set = latticeSet("{min: [0, 0, 0.002], max: [0.01, 0.01, 0.01]}", "0.001");
  const std::string box = "  - box: {min: [-0.001, -0.001, 0], max: [0.011, 0.011, 0.02]}\n    name: pan\n";
  const auto press = loadSceneFromString(minimalScene(set, "  duration: 0.1\n", box + "    motion: {velocity: [0, 0, -0.01], drive: {mass: 2, force_limit: 50}}\n"));
  ASSERT_TRUE(press.isOk()) << errorText(press);
  const auto& m = press->config.meshes[0].motion;
  ASSERT_TRUE(m.drive.has_value());
  EXPECT_DOUBLE_EQ(m.drive->mass, 2);
  EXPECT_DOUBLE_EQ(m.drive->forceLimit, 50);
  EXPECT_TRUE(m.moves());
  // An inline mesh without `surfaces` has its area (it was reported as 0).
  const auto plate = loadSceneFromString(minimalScene(
      set, "  duration: 0.1\n",
      "  - mesh: {vertices: [[0, 0, 0.03], [0.01, 0, 0.03], [0.01, 0.01, 0.03], [0, 0.01, 0.03]], triangles: [[0, 2, 1], [0, 3, 2]]}\n"
      "    name: press\n    motion: {drive: {mass: 1, force: [0, 0, -1]}}\n"));
  ASSERT_TRUE(plate.isOk()) << errorText(plate);
  ASSERT_EQ(plate->surfaces.size(), 1u);
  EXPECT_NEAR(plate->surfaces[0].area, 1e-4, 1e-12);
  const auto motor = loadSceneFromString(minimalScene(set, "  duration: 0.1\n", box + "    motion: {angular_velocity: 2, axis: [0, 0, 1], drive: {moment_of_inertia: 0.4, torque_limit: 3}}\n"));
  ASSERT_TRUE(motor.isOk()) << errorText(motor);
  EXPECT_DOUBLE_EQ(motor->config.meshes[0].motion.drive->torqueLimit, 3);
  struct Case {
    const char* motion;
    const char* expected;
  };
  for (const Case& c : {Case{"{drive: {mass: 2}}", "drive.force: a translation drive (mass 2 kg) needs force (N) or force_limit (N)"},
                        Case{"{drive: {mass: 2, force_limit: 5}}", "velocity: force_limit holds a velocity"},
                        Case{"{velocity: [0, 0, 1], drive: {mass: 2, force: [0, 0, 1], force_limit: 5}}", "not both"},
                        Case{"{drive: {force: [0, 0, 1]}}", "drive.mass: a drive force needs the wall's mass"},
                        Case{"{drive: {moment_of_inertia: 1, torque: 2}, vibration: {amplitude: [0, 0, 0.001], frequency: 5}}", "no vibration beside it"},
                        Case{"{drive: {moment_of_inertia: 1}}", "drive.torque: a rotation drive"},
                        Case{"{drive: {mass: 1, forse: 3}}", "unknown key 'forse'; did you mean 'force'?"},
                        Case{"{drive: {}}", "drives nothing"}}) {
    const auto bad = loadSceneFromString(minimalScene(set, "  duration: 0.1\n", box + "    motion: " + c.motion + "\n"));
    EXPECT_HAS(errorText(bad), c.expected);
  }
}
}  // namespace
}  // namespace pflow::frontend
