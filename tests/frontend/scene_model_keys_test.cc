// Scene keys of the least model and the accuracy target: simulation.model, simulation.accuracy (and that
// simulation.precision marks the precision as the scene's own). Bad values are named with their field.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "frontend/SceneLoader.h"
#include "frontend/SceneSummary.h"

namespace pflow::frontend {
namespace {

std::string scene(const std::string& simulationExtra) {
  return "materials:\n"
         "  - {name: glass, youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.0}\n"
         "particles:\n"
         "  - material: glass\n"
         "    list:\n"
         "      - {position: [0, 0, 0.01], radius: 0.001}\n"
         "      - {position: [0.003, 0, 0.01], radius: 0.001}\n"
         "simulation:\n"
         "  duration: 0.001\n" +
         simulationExtra;
}

compute::AccuracyTable fixture() {
  std::ifstream in(std::string(PFLOW_SOURCE_DIR) + "/tests/data/accuracy_study_fixture.csv");
  std::stringstream ss;
  ss << in.rdbuf();
  return compute::AccuracyTable::parse(ss.str()).value();
}

TEST(SceneModelKeys, DefaultsAndValues) {
  auto plain = loadSceneFromString(scene(""));
  ASSERT_TRUE(plain.isOk()) << plain.status().toString();
  EXPECT_EQ(plain.value().config.sim.model, compute::ModelMode::kAuto);
  EXPECT_FALSE(plain.value().config.sim.accuracy.has_value());
  EXPECT_FALSE(plain.value().config.sim.precisionGiven);

  const compute::AccuracyTable table = fixture();
  LoadOptions o;
  o.accuracyTable = &table;
  auto set = loadSceneFromString(scene("  model: full\n  precision: double\n  accuracy: {quantity: restitution, tolerance: 0.01}\n"),
                                 "s.yaml", o);
  ASSERT_TRUE(set.isOk()) << set.status().toString();
  const auto& sim = set.value().config.sim;
  EXPECT_EQ(sim.model, compute::ModelMode::kFull);
  EXPECT_TRUE(sim.precisionGiven);
  ASSERT_TRUE(sim.accuracy.has_value());
  EXPECT_EQ(sim.accuracy->quantity, "restitution");
  EXPECT_DOUBLE_EQ(sim.accuracy->tolerance, 0.01);
}

TEST(SceneModelKeys, BadValuesNameTheirFields) {
  const compute::AccuracyTable table = fixture();
  LoadOptions o;
  o.accuracyTable = &table;
  auto bad = loadSceneFromString(scene("  model: least\n  accuracy: {quantity: restitutoin, tolerance: -0.1}\n"), "s.yaml", o);
  ASSERT_FALSE(bad.isOk());
  const std::string m = bad.status().message();
  EXPECT_NE(m.find("simulation.model"), std::string::npos) << m;
  EXPECT_NE(m.find("unknown model 'least'"), std::string::npos) << m;
  EXPECT_NE(m.find("simulation.accuracy.quantity"), std::string::npos) << m;
  EXPECT_NE(m.find("did you mean 'restitution'?"), std::string::npos) << m;
  EXPECT_NE(m.find("restitution, runout"), std::string::npos) << m;
  EXPECT_NE(m.find("simulation.accuracy.tolerance"), std::string::npos) << m;

  auto missing = loadSceneFromString(scene("  accuracy: {tolerance: 0.01, error: 1}\n"), "s.yaml", o);
  ASSERT_FALSE(missing.isOk());
  EXPECT_NE(missing.status().message().find("simulation.accuracy.quantity"), std::string::npos) << missing.status().message();
  EXPECT_NE(missing.status().message().find("simulation.accuracy.error"), std::string::npos) << missing.status().message();
}

TEST(SceneModelKeys, SummaryListsTheModel) {
  const compute::AccuracyTable table = fixture();
  LoadOptions o;
  o.accuracyTable = &table;
  auto s = loadSceneFromString(scene(""), "s.yaml", o);
  ASSERT_TRUE(s.isOk());
  auto summary = summarize(s.value());
  ASSERT_TRUE(summary.isOk());
  const std::string text = summary.value().model.text();
  EXPECT_NE(text.find("tangential history: off"), std::string::npos) << text;
  EXPECT_NE(text.find("wall contact: off"), std::string::npos) << text;
  EXPECT_NE(toJson(summary.value()).find("\"model\":[{"), std::string::npos);
}

// slurm: what the job asks of Slurm under the manager's --placement slurm (docs/cluster.md).
TEST(SceneSlurmKeys, ValuesAndErrors) {
  auto plain = loadSceneFromString(scene(""));
  ASSERT_TRUE(plain) << plain.status().toString();
  EXPECT_TRUE(plain.value().slurm.partition.empty());
  auto set = loadSceneFromString(scene("slurm: {partition: gpu-h100, account: proj.42, time_limit: 1-12:00:00}\n"));
  ASSERT_TRUE(set) << set.status().toString();
  EXPECT_EQ(set.value().slurm.partition, "gpu-h100");
  EXPECT_EQ(set.value().slurm.account, "proj.42");
  EXPECT_EQ(set.value().slurm.timeLimit, "1-12:00:00");
  for (const char* ok : {"90", "30:00", "2:00:00", "3-12", "UNLIMITED"})
    EXPECT_TRUE(loadSceneFromString(scene(std::string("slurm: {time_limit: \"") + ok + "\"}\n"))) << ok;
  auto bad = loadSceneFromString(scene("slurm: {partition: 'gpu; rm -rf', time_limit: 1:2:3:4, qos: high}\n"));
  ASSERT_FALSE(bad);
  const std::string msg = bad.status().message();
  EXPECT_NE(msg.find("slurm.partition"), std::string::npos) << msg;
  EXPECT_NE(msg.find("slurm.time_limit"), std::string::npos) << msg;
  EXPECT_NE(msg.find("qos"), std::string::npos) << msg;
}

}  // namespace
}  // namespace pflow::frontend
