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

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) out.push_back(f);
  return out;
}

TEST(AccuracyStudy, QuickRunWritesTheStudyAndFinestSettingsAreAccurate) {
  const auto dir = std::filesystem::temp_directory_path() / "pflow_accuracy_smoke";
  std::filesystem::remove_all(dir);
  const std::string cmd = std::string(PFLOW_ACCURACY_BIN) + " --quick --threads 1 --out " + dir.string() + " 2>" +
                          (dir.parent_path() / "pflow_accuracy_smoke.log").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  std::ifstream in(dir / "study.csv");
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line,
            "problem,quantity,reference,executor,precision,dt_fraction,softening,skin_fraction,rebuild_interval,value,"
            "error,wall_s_per_sim_s,steps,status");
  // (problem, quantity) -> error at the finest step in double, E/1, default skin, automatic rebuilds.
  std::map<std::pair<std::string, std::string>, double> finest;
  std::map<std::string, std::string> statusAtLargest;  // problem -> status at dt = 5 Rayleigh times
  int rows = 0;
  while (std::getline(in, line)) {
    const auto f = split(line);
    ASSERT_EQ(f.size(), 14u) << line;
    ++rows;
    if (f[4] == "double" && f[5] == "0.01" && f[6] == "1" && f[7] == "0.1" && f[8] == "0") {
      EXPECT_EQ(f[13], "ok") << line;
      finest[{f[0], f[1]}] = std::stod(f[10]);
    }
    if (f[5] == "5" && f[4] == "double") statusAtLargest[f[0]] = f[13];
  }
  EXPECT_GT(rows, 20);
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
  // Five Rayleigh times is past the point of failure of every problem, and the study says so.
  for (const auto& [problem, status] : statusAtLargest) EXPECT_NE(status, "ok") << problem;
  EXPECT_TRUE(std::filesystem::exists(dir / "stability.csv"));
}

}  // namespace
