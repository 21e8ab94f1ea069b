// Table-driven: malformed scenes, each must give its precise message (key path and what is wrong) and never crash.
// Covers wrong types, missing and unknown keys, negative / NaN values, regions outside the domain, particles that
// cannot fit, unreadable or corrupt mesh and particle files, cyclic and empty definitions.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "frontend/SceneLoader.h"

namespace pflow::frontend {
namespace {

namespace fs = std::filesystem;

const std::string kMat =
    "materials:\n"
    "  - {name: glass, youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5}\n";
const std::string kSim = "simulation: {duration: 0.1}\n";

// A scene of one material, the given particles and geometry (YAML list items), and kSim.
std::string scene(const std::string& particles, const std::string& geometry = "", const std::string& sim = kSim) {
  std::string s = kMat;
  if (!particles.empty()) s += "particles:\n" + particles;
  if (!geometry.empty()) s += "geometry:\n" + geometry;
  return s + sim;
}
const std::string kBoxSet = "  - {method: lattice, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: 0.001}\n";

struct Case {
  const char* name;
  std::string yaml;
  std::vector<std::string> expect;  // each must appear in the error text
};

class MalformedScenes : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir = fs::temp_directory_path() / ("pflow_malformed_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    auto write = [](const std::string& name, const std::string& bytes) {
      std::ofstream(dir / name, std::ios::binary) << bytes;
    };
    std::string truncated(84, '\0');
    truncated[80] = 10;  // header says 10 triangles, none follow
    write("truncated.stl", truncated + std::string(30, '\0'));
    write("garbage.stl", "solid x\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 zero\n");
    write("nan.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n");
    write("empty.obj", "");
    write("ok.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n");
    write("badindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    write("mesh.ply", "ply\n");
    write("nocol.csv", "x,y,z\n0,0,0\n");
    write("badnum.csv", "x,y,z,radius\n0,0,0,0.001\n0,0,abc,0.001\n");
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }
  static inline fs::path dir;

  std::string load(const std::string& yaml) {
    LoadOptions options;
    options.baseDir = dir.string();
    options.maxParticles = 100000;
    auto r = loadSceneFromString(yaml, "case.yaml", options);
    return r.isOk() ? std::string("(loaded fine)") : r.status().message();
  }
};

TEST_F(MalformedScenes, EachGivesItsPreciseMessage) {
  const std::string ok = kBoxSet;
  const std::vector<Case> cases = {
      // ---- structure
      {"empty file", "", {"the scene is empty"}},
      {"only a comment", "# nothing\n", {"the scene is empty"}},
      {"YAML syntax", "materials: [\n", {"YAML syntax error"}},
      {"top level is a list", "- a\n- b\n", {"expected a mapping with keys materials"}},
      {"unknown top-level key", kMat + kSim + "particle:\n  - {}\n", {"particle: unknown key 'particle'; did you mean 'particles'?"}},
      {"duplicate key", kMat + "simulation: {duration: 0.1, duration: 0.2}\n", {"simulation.duration: duplicate key 'duration'"}},
      {"missing simulation", kMat, {"simulation: required key 'simulation' is missing"}},
      {"missing duration", kMat + "simulation: {dt: 1e-6}\n", {"simulation.duration: required key 'duration' is missing"}},
      {"cyclic alias", "materials: &m [{name: glass, youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5, rolling_friction: *m}]\n" + kSim,
       {"materials[0].rolling_friction: a cyclic alias"}},
      {"deep nesting", kMat + kSim + "output: {fields: " + std::string(200, '[') + std::string(200, ']') + "}\n", {"nested deeper than 64 levels"}},
      // ---- wrong types and values
      {"number as text", kMat + "simulation: {duration: abc}\n", {"simulation.duration: expected a number, got 'abc'"}},
      {"quoted number", kMat + "simulation: {duration: \"0.1\"}\n", {"(write numbers without quotes)"}},
      {"vector of 2", kMat + "simulation: {duration: 0.1, gravity: [0, -9.81]}\n", {"simulation.gravity: expected a list of 3 numbers [x, y, z], got a list of 2 items"}},
      {"negative duration", kMat + "simulation: {duration: -1}\n", {"simulation.duration: -1 must be > 0"}},
      {"NaN duration", kMat + "simulation: {duration: .nan}\n", {"simulation.duration: nan is not a finite number"}},
      {"zero dt", kMat + "simulation: {duration: 0.1, dt: 0}\n", {"simulation.dt: 0 must be > 0"}},
      {"bad precision", kMat + "simulation: {duration: 0.1, precision: doubel}\n", {"simulation.precision: unknown precision 'doubel'; did you mean 'double'?"}},
      // ---- materials
      {"no materials", "materials: []\n" + kSim, {"materials: at least one material is required"}},
      {"material key typo", "materials:\n  - {name: glass, youngs_modulis: 1e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5}\n" + kSim,
       {"materials[0].youngs_modulis: unknown key 'youngs_modulis'; did you mean 'youngs_modulus'?", "materials[0].youngs_modulus: required key 'youngs_modulus' is missing"}},
      {"Poisson ratio 0.5", "materials:\n  - {name: glass, youngs_modulus: 1e7, poisson_ratio: 0.5, density: 2500, restitution: 0.5, friction: 0.5}\n" + kSim,
       {"materials[0].poisson_ratio: 0.5 is outside (-1, 0.5)"}},
      {"restitution 0", "materials:\n  - {name: glass, youngs_modulus: 1e7, poisson_ratio: 0.3, density: 2500, restitution: 0, friction: 0.5}\n" + kSim,
       {"materials[0].restitution: 0 is outside (0, 1]"}},
      {"negative density", "materials:\n  - {name: glass, youngs_modulus: 1e7, poisson_ratio: 0.3, density: -1, restitution: 0.5, friction: 0.5}\n" + kSim,
       {"materials[0].density: -1 must be > 0"}},
      {"unknown material", scene("  - {material: glas, method: lattice, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: 0.001}\n"),
       {"particles[0].material: unknown material 'glas'; did you mean 'glass'?"}},
      {"pair of unknown material", kMat + "pairs:\n  - {materials: [glass, steel], friction: 0.1}\n" + kSim, {"pairs[0].materials[1]: unknown material 'steel'"}},
      {"adhesion model typo", kMat + "pairs:\n  - {materials: [glass, glass], cohesion: {model: jrk, work_of_adhesion: 0.1}}\n" + kSim,
       {"pairs[0].cohesion.model: unknown model 'jrk'; did you mean 'jkr'?"}},
      {"adhesion without its work", kMat + "pairs:\n  - {materials: [glass, glass], cohesion: {model: jkr}}\n" + kSim,
       {"pairs[0].cohesion.work_of_adhesion: required key 'work_of_adhesion' is missing"}},
      {"negative work of adhesion", kMat + "pairs:\n  - {materials: [glass, glass], cohesion: {model: constant, work_of_adhesion: -1}}\n" + kSim,
       {"pairs[0].cohesion.work_of_adhesion: must be > 0 (J/m^2), got -1"}},
      {"adhesion beyond the skin",
       kMat + "pairs:\n  - {materials: [glass, glass], cohesion: {model: jkr, work_of_adhesion: 50}}\n" +
           "particles:\n  - {method: lattice, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: 0.001}\n" +
           "simulation: {duration: 0.1, skin: 1.0e-6}\n",
       {"pairs[0].cohesion.work_of_adhesion: 50 J/m^2 lets a JKR contact of the largest particles hold", "raise simulation.skin above"}},
      // ---- particle sets
      {"particles not a list", kMat + "particles: {method: lattice}\n" + kSim, {"particles: expected a list of particle sets"}},
      {"empty set", scene("  - {}\n"), {"particles[0].method: required key 'method' is missing"}},
      {"unknown method", scene("  - {method: lattise, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: 0.001}\n"),
       {"particles[0].method: unknown method 'lattise'; did you mean 'lattice'?"}},
      {"negative size", scene("  - {method: lattice, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: -0.001}\n"), {"particles[0].size: -0.001 must be > 0"}},
      {"unknown distribution", scene("  - {method: random, count: 10, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: {distribution: gauss, mean: 0.001}}\n"),
       {"particles[0].size.distribution: unknown distribution 'gauss'"}},
      {"uniform min > max", scene("  - {method: random, count: 10, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: {distribution: uniform, min: 0.002, max: 0.001}}\n"),
       {"particles[0].size.min: 0.002 must be <= max 0.001"}},
      {"parameter of another distribution", scene("  - {method: random, count: 10, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: {distribution: uniform, min: 0.001, max: 0.002, median: 0.001}}\n"),
       {"particles[0].size.median: 'median' is not a parameter of a uniform distribution (it takes min, max)"}},
      {"fractions not summing to 1", scene("  - {method: random, count: 10, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}, size: {distribution: discrete, radii: [0.001, 0.0005], fractions: [0.5, 0.6]}}\n"),
       {"particles[0].size.fractions: sum to 1.1; fractions by number must sum to 1 within 1e-6"}},
      {"missing region", scene("  - {method: random, count: 10, size: 0.001}\n"), {"particles[0].region: required key 'region' is missing"}},
      // A lattice without a count fills its region: one of 10^6 sites, over the limit of 10^5, is refused before
      // a site is generated (found by the fuzzer as a 30 s input).
      {"lattice filling a region beyond the limit", scene("  - {method: lattice, region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, size: 0.004, lattice: {spacing: 0.01}}\n"),
       {"particles[0]: fills its region with about 1e+06 lattice particles; the limit is 100000 in all (give a count or a larger spacing)"}},
      // A tiled set without a count or solid_fraction fills its region at the tile's 0.3: refused before a tile is made
      // (found by the fuzzer as a 33 s input: 2*10^7 particles generated before they were counted).
      {"tiled set filling a region beyond the limit", scene("  - {method: tiled, region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, size: 0.001}\n"),
       {"particles[0]: fills its region with about 7.16197e+07 particles (the tile's solid fraction 0.3); the limit is 100000 in all"}},
      {"inverted region", scene("  - {method: random, count: 10, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, -0.01, 0.01]}}}\n"),
       {"particles[0].region.box: max [0.01, -0.01, 0.01] must be > min [0, 0, 0] on every axis"}},
      {"region names an unknown wall", scene("  - {method: random, count: 10, size: 0.001, region: {mesh: bim}}\n", "  - {name: bin, box: {min: [0, 0, 0], max: [0.1, 0.1, 0.1]}}\n"),
       {"particles[0].region.mesh: unknown mesh wall 'bim'; did you mean 'bin'?"}},
      {"region is an open wall", scene("  - {method: random, count: 10, size: 0.001, region: {mesh: bin}}\n", "  - {name: bin, box: {min: [0, 0, 0], max: [0.1, 0.1, 0.1], open: [top]}}\n"),
       {"particles[0].region.mesh: wall 'bin' cannot be a region"}},
      {"count and solid fraction", scene("  - {method: random, count: 10, solid_fraction: 0.2, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0]: give either 'count' or 'solid_fraction', not both"}},
      {"random without count", scene("  - {method: random, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0].count: required key 'count' is missing"}},
      {"cannot fit", scene("  - {method: random, count: 1000, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0]:", "placed"}},
      {"solid fraction too high", scene("  - {method: random, solid_fraction: 0.8, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0].solid_fraction: 0.8 is outside (0, 0.74)"}},
      {"solid fraction on a lattice", scene("  - {method: lattice, solid_fraction: 0.3, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0].solid_fraction: 'solid_fraction' does not apply to a lattice"}},
      {"options of another method", scene("  - {method: random, count: 5, tiled: {tile_size: 0.01}, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0].tiled: 'tiled' options apply to method tiled, and this set's method is random"}},
      {"tile smaller than two diameters", scene("  - {method: tiled, tiled: {tile_size: 0.001}, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0].tiled.tile_size: 0.001 must be >= 2 x the largest diameter 0.002"}},
      {"lattice jitter too large", scene("  - {method: lattice, lattice: {spacing: 0.0021, jitter: 0.5}, size: 0.001, region: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}}}\n"),
       {"particles[0].lattice.jitter: 0.5 lets neighbouring particles overlap"}},
      {"region outside the domain", scene(kBoxSet, "", "simulation: {duration: 0.1, domain: {min: [0, 0, 0], max: [0.005, 0.005, 0.005]}}\n"),
       {"particles[0].region: particle 2 of this set (particles.position[2]): centre", "lies outside simulation.domain"}},
      {"region behind a plane", scene(kBoxSet, "  - {plane: {point: [0, 0, 0.5], normal: [0, 0, 1]}}\n"), {"particles[0].region: no particle fits"}},
      {"list particle behind a plane", scene("  - list: [{position: [0, 0, -0.01], radius: 0.001}]\n", "  - {name: floor, plane: {point: [0, 0, 0], normal: [0, 0, 1]}}\n"),
       {"particles[0].list[0].position: centre [0, 0, -0.01] lies behind plane 'floor'"}},
      {"list particle NaN radius", scene("  - list: [{position: [0, 0, 0], radius: .nan}]\n"), {"particles[0].list[0].radius: nan is not a finite number"}},
      {"list set with a bad velocity, reported once", scene("  - {velocity: [1, 2], list: [{position: [0, 0, 0], radius: 0.001}]}\n"),
       {"case.yaml: 1 error(s)", "particles[0].velocity: expected a list of 3 numbers"}},
      {"list and size", scene("  - {list: [{position: [0, 0, 0], radius: 0.001}], size: 0.001}\n"), {"particles[0].size: 'size' applies to generated sets"}},
      {"missing CSV file", scene("  - {file: nofile.csv}\n"), {"particles[0].file:", "nofile.csv"}},
      {"CSV without radius column", scene("  - {file: nocol.csv}\n"), {"particles[0].file:", "radius"}},
      {"CSV bad number", scene("  - {file: badnum.csv}\n"), {"particles[0].file:", "badnum.csv", "line 3, column 5", "column 'z': 'abc' is not a finite number"}},
      // ---- geometry
      {"empty wall", scene(ok, "  - {}\n"), {"geometry[0]: expected one shape key: plane, box, cylinder, cone, hopper, drum, mesh"}},
      {"two shapes", scene(ok, "  - {plane: {point: [0, 0, 0], normal: [0, 0, 1]}, box: {min: [0, 0, 0], max: [1, 1, 1]}}\n"), {"geometry[0]: give only one shape per entry"}},
      {"zero plane normal", scene(ok, "  - {plane: {point: [0, 0, -1], normal: [0, 0, 0]}}\n"), {"geometry[0].plane.normal"}},
      {"cylinder radius 0", scene(ok, "  - {cylinder: {base: [0, 0, 0], radius: 0, height: 1}}\n"), {"geometry[0].cylinder.radius: 0 must be > 0"}},
      {"cylinder axis zero", scene(ok, "  - {cylinder: {base: [0, 0, 0], axis: [0, 0, 0], radius: 1, height: 1}}\n"), {"geometry[0].cylinder.axis: [0, 0, 0] must be a finite, nonzero direction"}},
      {"two segments", scene(ok, "  - {cylinder: {base: [0, 0, 0], radius: 1, height: 1, segments: 2}}\n"), {"geometry[0].cylinder.segments: 2 is outside [3, 100000]"}},
      {"cap name typo", scene(ok, "  - {cylinder: {base: [0, 0, 0], radius: 1, height: 1, open: [tpo]}}\n"), {"geometry[0].cylinder.open[0]: unknown cap 'tpo'; did you mean 'top'?"}},
      {"hopper orifice wider than top", scene(ok, "  - {hopper: {orifice: [0, 0, -1], orifice_radius: 0.05, top_radius: 0.03, cone_height: 0.02}}\n"),
       {"geometry[0].hopper.orifice_radius: 0.05 must be < top_radius 0.03"}},
      {"drum with motion", scene(ok, "  - {drum: {center: [0, 0, 0], radius: 1, length: 1}, motion: {velocity: [1, 0, 0]}}\n"), {"geometry[0].motion: a drum turns by its own 'angular_velocity'"}},
      {"plane with motion", scene(ok, "  - {plane: {point: [0, 0, -1], normal: [0, 0, 1]}, motion: {velocity: [1, 0, 0]}}\n"), {"geometry[0].motion: planes cannot move"}},
      {"missing mesh file", scene(ok, "  - {mesh: {file: nothere.stl}}\n"), {"geometry[0].mesh.file:", "nothere.stl"}},
      {"truncated binary STL", scene(ok, "  - {mesh: {file: truncated.stl}}\n"), {"geometry[0].mesh.file:", "truncated.stl"}},
      {"corrupt ASCII STL", scene(ok, "  - {mesh: {file: garbage.stl}}\n"), {"geometry[0].mesh.file:", "garbage.stl' line 4: expected a vertex coordinate, got 'zero'"}},
      {"NaN in an STL", scene(ok, "  - {mesh: {file: nan.stl}}\n"), {"geometry[0].mesh.file:", "nan.stl"}},
      {"empty OBJ", scene(ok, "  - {mesh: {file: empty.obj}}\n"), {"geometry[0].mesh.file:", "empty.obj"}},
      {"OBJ index out of range", scene(ok, "  - {mesh: {file: badindex.obj}}\n"), {"geometry[0].mesh.file:", "badindex.obj' line 4: face vertex index 7 is out of range (the file has 3 vertices)"}},
      {"unknown mesh format", scene(ok, "  - {mesh: {file: mesh.ply}}\n"), {"geometry[0].mesh.file:", "mesh.ply"}},
      {"file and inline mesh", scene(ok, "  - {mesh: {file: x.stl, vertices: [[0, 0, 0]], triangles: [[0, 0, 0]]}}\n"), {"geometry[0].mesh: give either 'file' or inline"}},
      {"negative scale", scene(ok, "  - {mesh: {file: ok.stl, scale: -1}}\n"), {"geometry[0].mesh.scale: -1 must be > 0"}},
      {"duplicate wall names", scene(ok, "  - {name: w, plane: {point: [0, 0, -1], normal: [0, 0, 1]}}\n  - {name: w, plane: {point: [0, 0, 2], normal: [0, 0, -1]}}\n"),
       {"geometry[1].name: 'w' is already the name of geometry[0]"}},
      // ---- output
      {"unknown output field", scene(ok, "", kSim + "output: {fields: [velocty]}\n"), {"output.fields[0]: unknown field 'velocty'; did you mean 'velocity'?"}},
  };
  ASSERT_GE(cases.size(), 40u);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string text = load(c.yaml);
    for (const std::string& part : c.expect)
      EXPECT_NE(text.find(part), std::string::npos) << "case '" << c.name << "'\nwant: " << part << "\ngot:\n" << text;
  }
}

}  // namespace
}  // namespace pflow::frontend
