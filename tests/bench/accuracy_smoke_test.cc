// Smoke test of the accuracy study: `pflow-accuracy --quick` runs, writes study.csv with the columns that
// `pflow validate` reads, and its finest settings match the closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "compute/dem/AccuracyTable.h"

namespace pflow {
namespace {

TEST(AccuracyStudy, QuickRunWritesTheStudyAndFinestSettingsAreAccurate) {
  const auto dir = std::filesystem::temp_directory_path() / "pflow_accuracy_smoke";
  std::filesystem::remove_all(dir);
  const std::string cmd = std::string(PFLOW_ACCURACY_BIN) + " --quick --threads 1 --out " + dir.string() + " 2>" +
                          (dir.parent_path() / "pflow_accuracy_smoke.log").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  // Read as `pflow validate` reads it: any malformed line is an error.
  std::ifstream in(dir / "study.csv");
  std::stringstream text;
  text << in.rdbuf();
  const auto table = compute::AccuracyTable::parse(text.str(), "study.csv");
  ASSERT_TRUE(table.isOk()) << table.status().toString();
  // (problem, quantity) -> error at the finest step in double, E/1, default skin, automatic rebuilds.
  std::map<std::pair<std::string, std::string>, double> finest;
  std::map<std::string, std::string> statusAtLargest;  // problem -> status at dt = 5 Rayleigh times
  const auto& all = table.value().rows();
  const std::size_t rows = all.size();
  for (const auto& r : all) {
    if (r.precision == "double" && r.dtFraction == 0.01 && r.softening == 1 && r.skinFraction == 0.1 &&
        r.rebuildInterval == 0) {
      EXPECT_EQ(r.status, "ok") << r.problem << " " << r.quantity;
      finest[{r.problem, r.quantity}] = r.error;
    }
    if (r.dtFraction == 5 && r.precision == "double") statusAtLargest[r.problem] = r.status;
  }
  EXPECT_GT(rows, 20u);
  // Chung & Ooi test 1 (glass) and 2 (aluminium) at dt = 0.01 T_R: within 1 % of the Hertz closed forms.
  for (const char* p : {"chung_ooi_1/glass", "chung_ooi_2/aluminium"})
    for (const char* q : {"delta_max", "f_max", "contact_time", "rebound_speed"}) {
      ASSERT_TRUE(finest.count({p, q})) << p << " " << q;
      EXPECT_LT((finest[{p, q}]), 0.01) << p << " " << q;
    }
  ASSERT_TRUE(finest.count({"restitution/alumina_e0.6", "restitution"}));
  EXPECT_LT((finest[{"restitution/alumina_e0.6", "restitution"}]), 0.01);
  for (const char* q : {"apex_rise_1", "apex_rise_2", "apex_rise_3"}) {
    ASSERT_TRUE(finest.count({"bouncing_sphere/e0.7", q})) << q;
    EXPECT_LT((finest[{"bouncing_sphere/e0.7", q}]), 0.02) << q;
  }
  // Five Rayleigh times is past the point of failure of every problem (the quick set's four), and the study says so.
  EXPECT_EQ(statusAtLargest.size(), 4u);
  for (const auto& [problem, status] : statusAtLargest) EXPECT_NE(status, "ok") << problem;
  EXPECT_TRUE(std::filesystem::exists(dir / "stability.csv"));
}

}  // namespace
}  // namespace pflow
