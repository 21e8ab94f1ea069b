// Probe series in the HDF5 file and as CSV (backend/store/ProbeSeries.h): written after the snapshots of a real
// snapshot file, read back value for value with units and points; the CSV's header names the units.
#include <gtest/gtest.h>

#include <filesystem>

#include "backend/store/ProbeSeries.h"
#include "backend/store/SnapshotFile.h"

namespace pflow::backend {
namespace {

TEST(SphProbeSeries, RoundTripThroughTheSnapshotFile) {
  const std::string path = (std::filesystem::temp_directory_path() / "pflow_probe_series_test.h5").string();
  auto writer = SnapshotWriter::create(path);
  ASSERT_TRUE(writer.isOk()) << writer.status().message();
  ASSERT_TRUE(writer.value()->writeGeometry({}).isOk());
  ASSERT_TRUE(writer.value()->close().isOk());
  ProbeSeries s;
  s.names = {"P1", "H2"};
  s.units = {"Pa", "m"};
  s.points = {{0.8245, 0.471, 0.021}, {0.992, 0.5, 0}};
  s.add(0.0, {0.0, 0.0});
  s.add(0.001, {512.5, 0.036});
  s.add(0.002, {11239.0, 0.081});
  ASSERT_TRUE(writeProbeSeries(path, s).isOk());
  ASSERT_TRUE(writeProbeSeries(path, s).isOk());  // replaces, does not fail on an existing /probes
  auto r = readProbeSeries(path);
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r.value().names, s.names);
  EXPECT_EQ(r.value().units, s.units);
  EXPECT_EQ(r.value().time, s.time);
  EXPECT_EQ(r.value().values, s.values);
  EXPECT_EQ(r.value().points[0].x, 0.8245);
  EXPECT_EQ(r.value().points[1].y, 0.5);
  const std::string csv = probeSeriesCsv(s);
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "time [s],P1 [Pa],H2 [m]");
  EXPECT_NE(csv.find("0.002,11239,0.081"), std::string::npos) << csv;
  // The snapshot file is still a snapshot file.
  auto reader = SnapshotReader::open(path);
  EXPECT_TRUE(reader.isOk()) << reader.status().message();
  std::filesystem::remove(path);
  EXPECT_FALSE(readProbeSeries(path).isOk());
}

}  // namespace
}  // namespace pflow::backend
