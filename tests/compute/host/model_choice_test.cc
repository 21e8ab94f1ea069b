// deriveModel (compute/dem/ModelChoice.h): each rule of the least model on small configurations, and
// simulation.model: full; AccuracyTable parsing and proposals on a fixture (tests/data/accuracy_study_fixture.csv).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "compute/dem/ModelChoice.h"
#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::AccuracyTable;
using compute::deriveModel;
using compute::ModelChoice;
using compute::RunConfig;

const compute::ModelDecision& decision(const ModelChoice& m, const std::string& name) {
  for (const auto& d : m.decisions)
    if (d.name == name) return d;
  static const compute::ModelDecision none{"", "", ""};
  ADD_FAILURE() << "no decision " << name;
  return none;
}

// Four discs in the x-y plane at z = 0.01, gravity along -y, a floor with normal +y; friction and rolling friction.
RunConfig planarScene(double mu = 0.5, double muRoll = 0.01) {
  RunConfig c;
  c.materials = {material("m", 1e7, 0.3, 2500, 0.5, mu, muRoll)};
  for (int k = 0; k < 4; ++k) addParticle(c, {0.003 * k, 0.002, 0.01}, 1e-3, 0, {0.1, 0, 0}, {0, 0, 3});
  c.planes.push_back(plane({0, 0, 0}, {0, 1, 0}, 0, "floor"));
  c.sim.gravity = {0, -9.81, 0};
  c.sim.duration = 1e-3;
  return c;
}

TEST(ModelChoice, PlanarSceneIs2D) {
  const ModelChoice m = deriveModel(planarScene());
  EXPECT_EQ(m.flags.planarAxis, 2);
  EXPECT_NE(decision(m, "dimensions").choice.find("2D"), std::string::npos);
  EXPECT_NE(decision(m, "dimensions").choice.find("x-y"), std::string::npos);
}

TEST(ModelChoice, EachBrokenPlanarConditionKeeps3D) {
  auto check = [](RunConfig c, const std::string& why) {
    const ModelChoice m = deriveModel(c);
    EXPECT_EQ(m.flags.planarAxis, -1) << why;
    EXPECT_EQ(decision(m, "dimensions").choice, "3D") << why;
    EXPECT_NE(decision(m, "dimensions").reason.find(why), std::string::npos) << decision(m, "dimensions").reason;
  };
  // Another centre off the plane: no axis shares one coordinate any more (x and y already differ).
  RunConfig off = planarScene();
  off.particles.position[3].z += 1e-4;
  check(off, "along z, the particle centres do not share one z coordinate");
  RunConfig vel = planarScene();
  vel.particles.velocity[1].z = 0.01;
  check(vel, "initial velocity along z");
  RunConfig spin = planarScene();
  spin.particles.angularVelocity[2].x = 1;
  check(spin, "spins about an axis other than z");
  RunConfig grav = planarScene();
  grav.sim.gravity = {0, -9.81, -0.1};
  check(grav, "gravity has a z component");
  RunConfig tilted = planarScene();
  tilted.planes[0].normal = {0, 1, 0.1};
  check(tilted, "plane 'floor' is not parallel to z");
  RunConfig mesh = planarScene();
  compute::MeshConfig mc;
  mc.name = "wall";
  mc.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
  mc.triangles = {{0, 1, 2}};
  mesh.meshes.push_back(mc);
  check(mesh, "triangle meshes");
}

TEST(ModelChoice, RoundOffOffThePlaneIsStillPlanar) {
  RunConfig c = planarScene();
  c.particles.position[2].z += 1e-15;
  EXPECT_EQ(deriveModel(c).flags.planarAxis, 2);
}

TEST(ModelChoice, FrictionlessDropsTangentialHistory) {
  RunConfig c = planarScene(0.0, 0.01);
  ModelChoice m = deriveModel(c);
  EXPECT_FALSE(m.flags.tangential);
  EXPECT_TRUE(m.flags.rolling);
  EXPECT_EQ(decision(m, "tangential history").choice, "off");
  EXPECT_NE(decision(m, "tangential history").reason.find("friction 0"), std::string::npos);
  // A pair override with friction brings it back, and the reason names the pair.
  c.materials.push_back(material("wall", 1e7, 0.3, 2500, 0.5, 0.0));
  compute::MaterialPairConfig pair;
  pair.a = 0;
  pair.b = 1;
  pair.friction = 0.3;
  c.pairs.push_back(pair);
  m = deriveModel(c);
  EXPECT_TRUE(m.flags.tangential);
  EXPECT_NE(decision(m, "tangential history").reason.find("'m' and 'wall' have friction 0.3"), std::string::npos)
      << decision(m, "tangential history").reason;
  // ... and the engine setup then keeps its slots; without friction it has none.
  EXPECT_EQ(compute::prepareEngineSetup(c).value().historySlots, 8);
  EXPECT_EQ(compute::prepareEngineSetup(planarScene(0.0)).value().historySlots, 0);
  EXPECT_EQ(compute::prepareEngineSetup(planarScene(0.0)).value().wallHistorySlots, 0);
}

TEST(ModelChoice, NoRollingFrictionDropsRollingTorque) {
  const ModelChoice m = deriveModel(planarScene(0.5, 0.0));
  EXPECT_TRUE(m.flags.tangential);
  EXPECT_FALSE(m.flags.rolling);
  EXPECT_EQ(decision(m, "rolling torque").choice, "off");
  const ModelChoice on = deriveModel(planarScene(0.5, 0.02));
  EXPECT_TRUE(on.flags.rolling);
  EXPECT_NE(decision(on, "rolling torque").reason.find("rolling friction 0.02"), std::string::npos);
}

TEST(ModelChoice, NoGeometryDropsWallPhases) {
  RunConfig c = planarScene();
  EXPECT_TRUE(deriveModel(c).flags.walls);
  c.planes.clear();
  const ModelChoice m = deriveModel(c);
  EXPECT_FALSE(m.flags.walls);
  EXPECT_NE(decision(m, "wall contact").reason.find("no planes"), std::string::npos);
}

TEST(ModelChoice, FullComputesEverything) {
  RunConfig c = planarScene(0.0, 0.0);
  c.planes.clear();
  c.sim.model = compute::ModelMode::kFull;
  const ModelChoice m = deriveModel(c);
  EXPECT_TRUE(m.full);
  EXPECT_EQ(m.flags.planarAxis, -1);
  EXPECT_TRUE(m.flags.tangential);
  EXPECT_TRUE(m.flags.rolling);
  EXPECT_TRUE(m.flags.walls);
  EXPECT_EQ(decision(m, "model").choice, "full");
  EXPECT_NE(decision(m, "tangential history").reason.find("simulation.model: full"), std::string::npos);
  EXPECT_EQ(compute::prepareEngineSetup(c).value().historySlots, 8);
}

TEST(ModelChoice, PlanarGridHasOneLayerAlongTheAxis) {
  const auto setup = compute::prepareEngineSetup(planarScene());
  ASSERT_TRUE(setup.isOk());
  EXPECT_EQ(setup.value().grid.nz, 1);
  EXPECT_GT(setup.value().grid.nx, 1);
  const double cell = setup.value().grid.cellSize;
  EXPECT_NEAR(setup.value().grid.lo.z, 0.01 - 0.5 * cell, 1e-15);
}

TEST(ModelChoice, CellSizeAndGpuCount) {
  RunConfig c = planarScene();
  compute::ModelOptions o;
  o.particlesPerGpu = 2;
  ModelChoice m = deriveModel(c, o);
  EXPECT_DOUBLE_EQ(m.cellSize, 2e-3 + 0.2e-3);  // 2 r_max + the default skin (0.1 of the largest diameter)
  EXPECT_EQ(m.gpus, 2);                          // 4 particles at 2 per GPU
  EXPECT_NE(decision(m, "cell size").reason.find("one cell size suits them"), std::string::npos);
  EXPECT_EQ(deriveModel(c).gpus, 1);
  // One particle 4x the others: the cell follows it, and the report says it is wasteful for the rest.
  c.particles.radius[0] = 4e-3;
  m = deriveModel(c);
  EXPECT_DOUBLE_EQ(m.cellSize, 8e-3 + 0.8e-3);
  EXPECT_NE(decision(m, "cell size").reason.find("polydisperse"), std::string::npos);
}

// ---- the accuracy table ----

std::string fixture() {
  std::ifstream in(std::string(PFLOW_SOURCE_DIR) + "/tests/data/accuracy_study_fixture.csv");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(AccuracyTable, ParsesTheFixture) {
  auto t = AccuracyTable::parse(fixture());
  ASSERT_TRUE(t.isOk()) << t.status().toString();
  EXPECT_EQ(t.value().rows().size(), 11u);
  EXPECT_EQ(t.value().quantities(), (std::vector<std::string>{"restitution", "runout"}));
  const auto& r = t.value().rows()[5];
  EXPECT_EQ(r.problem, "oblique");
  EXPECT_EQ(r.precision, "float");
  EXPECT_DOUBLE_EQ(r.dtFraction, 0.4);
  EXPECT_EQ(r.status, "energy_gain");
  EXPECT_DOUBLE_EQ(r.wallSecondsPerSimSecond, 4);
}

TEST(AccuracyTable, MalformedLinesAreErrorsNamingLineAndColumn) {
  const std::string header(AccuracyTable::kColumns);
  auto bad = AccuracyTable::parse(header + "\nimpact,restitution,a,cuda,half,x,1,0.1,0,0.5,0.01,1,10,ok\nshort,line\n", "t.csv");
  ASSERT_FALSE(bad.isOk());
  const std::string m = bad.status().message();
  EXPECT_NE(m.find("t.csv:2 column precision"), std::string::npos) << m;
  EXPECT_NE(m.find("t.csv:2 column dt_fraction"), std::string::npos) << m;
  EXPECT_NE(m.find("t.csv:3"), std::string::npos) << m;
  auto header2 = AccuracyTable::parse("problem,quantity\n", "t.csv");
  ASSERT_FALSE(header2.isOk());
  EXPECT_NE(header2.status().message().find("header"), std::string::npos);
  EXPECT_TRUE(AccuracyTable::parse("").value().empty());
}

TEST(AccuracyTable, ProposesTheCheapestSettingsPerExecutor) {
  const AccuracyTable t = AccuracyTable::parse(fixture()).value();
  // 1 %: on cuda float at dt_fraction 0.2 (worst 0.8 % over both problems; 0.4 gains energy on one); on the cpu
  // double is cheaper than float (which misses on the oblique problem anyway).
  auto p = t.propose("restitution", 0.01);
  ASSERT_TRUE(p.isOk());
  ASSERT_EQ(p.value().size(), 2u);
  EXPECT_EQ(p.value()[0].executor, "cpu");
  EXPECT_EQ(p.value()[0].precision, "double");
  EXPECT_DOUBLE_EQ(p.value()[0].worstError, 0.006);
  EXPECT_EQ(p.value()[1].executor, "cuda");
  EXPECT_EQ(p.value()[1].precision, "float");
  EXPECT_DOUBLE_EQ(p.value()[1].dtFraction, 0.2);
  EXPECT_DOUBLE_EQ(p.value()[1].worstError, 0.008);
  EXPECT_DOUBLE_EQ(p.value()[1].cost, 14);
  EXPECT_EQ(p.value()[1].problems, (std::vector<std::string>{"impact", "oblique"}));
  // 0.5 %: only double at dt_fraction 0.05 on cuda; nothing on the cpu.
  p = t.propose("restitution", 0.005);
  ASSERT_EQ(p.value().size(), 1u);
  EXPECT_EQ(p.value()[0].executor, "cuda");
  EXPECT_EQ(p.value()[0].precision, "double");
  EXPECT_DOUBLE_EQ(p.value()[0].dtFraction, 0.05);
  // Nothing meets 0.05 %.
  EXPECT_TRUE(t.propose("restitution", 0.0005).value().empty());
  // An unknown quantity names the known ones.
  auto unknown = t.propose("restitutoin", 0.01);
  ASSERT_FALSE(unknown.isOk());
  EXPECT_NE(unknown.status().message().find("known: restitution, runout"), std::string::npos) << unknown.status().message();
}

TEST(ModelChoice, AccuracyTargetChoosesFloatWhereTheStudyAllowsIt) {
  const AccuracyTable t = AccuracyTable::parse(fixture()).value();
  RunConfig c = planarScene();
  c.sim.accuracy = compute::AccuracyTarget{"restitution", 0.01};
  compute::ModelOptions o;
  o.table = &t;
  o.executor = "cuda";
  ModelChoice m = deriveModel(c, o);
  EXPECT_EQ(m.precision, compute::Precision::kFloat);
  EXPECT_EQ(decision(m, "precision").choice, "float");
  EXPECT_EQ(m.proposals.size(), 2u);
  EXPECT_NE(m.text().find("proposed for the accuracy target, cuda: precision float, dt_fraction 0.2"), std::string::npos)
      << m.text();
  o.executor = "cpu";  // the study proposes double there
  EXPECT_EQ(deriveModel(c, o).precision, compute::Precision::kDouble);
  // At the scene's own step only: float met 1 % on cuda at dt_fraction 0.2, not at 0.4 (energy gain on one
  // problem), so a scene at 0.3 stays double though the study has a float proposal.
  o.executor = "cuda";
  c.sim.dtFraction = 0.3;
  EXPECT_EQ(deriveModel(c, o).precision, compute::Precision::kDouble);
  c.sim.dtFraction = 0.2;
  o.executor = "";  // unknown: float only if every executor's proposal is float
  EXPECT_EQ(deriveModel(c, o).precision, compute::Precision::kDouble);
  // A precision fixed by the scene wins.
  o.executor = "cuda";
  c.sim.precisionGiven = true;
  EXPECT_EQ(deriveModel(c, o).precision, compute::Precision::kDouble);
  EXPECT_EQ(decision(deriveModel(c, o), "precision").reason, "simulation.precision");
  // An empty table says so.
  c.sim.precisionGiven = false;
  const AccuracyTable empty;
  o.table = &empty;
  EXPECT_NE(decision(deriveModel(c, o), "precision").reason.find("the accuracy table is empty"), std::string::npos);
}

// The table built into pflow (docs/accuracy/study.csv) parses and is not empty: otherwise every accuracy
// target would go without proposals and unchecked.
TEST(ModelChoice, BuiltInStudyTableParses) {
  std::ifstream in(std::string(PFLOW_SOURCE_DIR) + "/docs/accuracy/study.csv");
  ASSERT_TRUE(in) << "docs/accuracy/study.csv";
  std::stringstream text;
  text << in.rdbuf();
  const auto parsed = AccuracyTable::parse(text.str());
  ASSERT_TRUE(parsed.isOk()) << parsed.status().toString();
  EXPECT_GT(parsed.value().rows().size(), 1000u);
  EXPECT_EQ(AccuracyTable::builtIn().rows().size(), parsed.value().rows().size());
}

TEST(ModelChoice, AccuracyTargetIsValidated) {
  RunConfig c = planarScene();
  c.sim.accuracy = compute::AccuracyTarget{"", 0};
  const std::string errors = c.validate().toString();
  EXPECT_NE(errors.find("simulation.accuracy.quantity"), std::string::npos) << errors;
  EXPECT_NE(errors.find("simulation.accuracy.tolerance"), std::string::npos) << errors;
}

}  // namespace
}  // namespace pflow::test
