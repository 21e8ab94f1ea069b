// Probe series in the HDF5 file and as CSV (backend/store/ProbeSeries.h): written after the snapshots of a real
// snapshot file, read back value for value with units and points; the CSV's header names the units. The recorder's
// two samplings (output.probe_sampling: instant, mean) on a simulation whose readings are known functions of time.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>

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

// What ProbeRecorder reads of a simulation: its probes, time, readings and output schedule. One probe reads
// signal(t), a gauge reads 2 signal(t); steps of dt.
struct SignalSim {
  struct Probe {
    std::string name;
    Vec3d point;
    bool gauge;
  };
  std::vector<Probe> list{{"P1", {0.8245, 0.471, 0.021}, false}, {"H4", {2.638, 0.5, 0}, true}};
  std::function<double(double)> signal;
  double dt = 1e-4, t = 0;
  const std::vector<Probe>& probes() const { return list; }
  double time() const { return t; }
  bool outputDue() const { return false; }
  std::vector<double> probeValues() const { return {signal(t), 2 * signal(t)}; }
};

template <class F>
ProbeSeries record(double interval, bool mean, double end, F signal) {
  SignalSim sim;
  sim.signal = signal;
  ProbeRecorder rec(sim, interval, mean);
  for (int i = 1; i * sim.dt <= end * (1 + 1e-9); ++i) {
    sim.t = i * sim.dt;
    rec.sample(sim);
  }
  return rec.series();
}

// instant: the reading at the first step at or past each multiple of the interval.
TEST(SphProbeSeries, InstantSamplesAreTheStepsReadings) {
  const ProbeSeries s = record(1e-3, false, 5e-3, [](double t) { return 1000 * t; });
  ASSERT_EQ(s.time.size(), 6u);
  for (std::size_t i = 0; i < s.time.size(); ++i) {
    EXPECT_NEAR(s.time[i], 1e-3 * double(i), 1e-12);
    EXPECT_NEAR(s.values[0][i], 1000 * s.time[i], 1e-9);
    EXPECT_NEAR(s.values[1][i], 2000 * s.time[i], 1e-9);
  }
}

// mean: each sample the time average over the interval before it. A linear ramp's mean is its value at the
// window's middle (exactly: the readings joined by straight lines); a smooth signal's the integral to O(dt^2); a
// spike of one step within a window counts by its impulse (height x duration / interval), not by its height.
TEST(SphProbeSeries, MeanSamplesAverageEveryStepOfTheirInterval) {
  const ProbeSeries ramp = record(1e-3, true, 5e-3, [](double t) { return 1000 * t; });
  ASSERT_EQ(ramp.time.size(), 6u);
  EXPECT_EQ(ramp.values[0][0], 0.0);  // the start: a reading, nothing to average yet
  for (std::size_t i = 1; i < ramp.time.size(); ++i) {
    EXPECT_NEAR(ramp.time[i], 1e-3 * double(i), 1e-12);
    EXPECT_NEAR(ramp.values[0][i], 1000 * (ramp.time[i] - 0.5e-3), 1e-9) << i;
    EXPECT_NEAR(ramp.values[1][i], 2000 * (ramp.time[i] - 0.5e-3), 1e-9) << i;
  }
  const double w = 2 * M_PI * 50;  // 50 Hz
  const ProbeSeries wave = record(1e-3, true, 0.02, [w](double t) { return std::sin(w * t); });
  for (std::size_t i = 1; i < wave.time.size(); ++i) {
    const double t1 = wave.time[i], t0 = t1 - 1e-3;
    const double exact = (std::cos(w * t0) - std::cos(w * t1)) / (w * 1e-3);
    EXPECT_NEAR(wave.values[0][i], exact, 1e-4) << i;
  }
  // 87 kPa for one step of 0.1 ms inside the window (0.002, 0.003]: an integrating sensor of 1 ms sees 8.7 kPa.
  auto spike = [](double t) { return std::fabs(t - 2.5e-3) < 1e-9 ? 87e3 : 0.0; };
  const ProbeSeries point = record(1e-3, false, 5e-3, spike), mean = record(1e-3, true, 5e-3, spike);
  for (double v : point.values[0]) EXPECT_EQ(v, 0.0);  // every sample falls beside the spike
  EXPECT_NEAR(mean.values[0][3], 87e3 * 1e-4 / 1e-3, 1e-6);
  EXPECT_EQ(mean.values[0][2], 0.0);
  EXPECT_EQ(mean.values[0][4], 0.0);
}

}  // namespace
}  // namespace pflow::backend
