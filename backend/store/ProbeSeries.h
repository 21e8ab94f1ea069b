// Time series of an SPH run's probes and gauges (docs/output-format.md, "Probes"): written into the run's HDF5
// file under /probes after its snapshots (time [s], one dataset per probe with its unit and point), and as CSV
// (time then one column per probe). Read back for tests and `pflow fetch`.
#pragma once
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/core/VectorMath.h"

namespace pflow::backend {

// HDF5 is built without thread safety: every caller of the library holds this lock (SnapshotFile.cc).
std::recursive_mutex& hdf5Mutex();

struct ProbeSeries {
  std::vector<std::string> names;
  std::vector<std::string> units;   // "Pa" (pressure probe) or "m" (gauge height)
  std::vector<Vec3d> points;        // where each probe is [m]
  std::vector<double> time;         // [s]
  std::vector<std::vector<double>> values;  // values[probe][sample]
  void add(double t, const std::vector<double>& v) {
    time.push_back(t);
    values.resize(v.size());
    for (std::size_t k = 0; k < v.size(); ++k) values[k].push_back(v[k]);
  }
};

// An SPH run's probes as they are sampled (`pflow run` and the worker): the series' names, units and points from
// the scene's probes (SphSimulation::probes(): name, point, gauge), a sample at the start, then every `interval`
// seconds of simulated time at the first step at or past each multiple, or, with interval 0, at every snapshot
// (the simulation's outputDue()). A sample is the reading at that step (`mean` false: output.probe_sampling:
// instant) or the time average of the readings since the previous sample (`mean`: output.probe_sampling: mean; the
// readings of every step, joined by straight lines, integrated and divided by the time between the two samples: a
// sensor that integrates over the record's interval, so that a spike shorter than the interval counts by its
// impulse, not by its height). `Sim` is compute::sph::SphSimulation (a template: no link dependency); sampling is
// collective in a distributed run, so every rank calls sample() after every step.
class ProbeRecorder {
 public:
  template <class Sim>
  ProbeRecorder(const Sim& sim, double interval, bool mean = false) : m_interval(interval), m_next(interval), m_mean(mean) {
    for (const auto& p : sim.probes()) {
      m_series.names.push_back(p.name);
      m_series.units.push_back(p.gauge ? "m" : "Pa");
      m_series.points.push_back(p.point);
    }
    if (empty()) return;
    m_last = sim.probeValues();
    m_lastTime = m_windowStart = sim.time();
    m_series.add(sim.time(), m_last);
    m_integral.assign(m_last.size(), 0.0);
    // A resumed run: the next samples where its run's fell (the interval's multiples, summed as sample() does).
    while (m_interval > 0 && m_next <= sim.time() * (1 + 1e-12)) m_next += m_interval;
  }
  template <class Sim>
  void sample(const Sim& s) {
    if (empty()) return;
    const bool due = m_interval > 0 ? s.time() >= m_next * (1 - 1e-12) : s.outputDue();
    if (!due && !m_mean) return;
    const std::vector<double> now = s.probeValues();
    if (m_mean) {
      const double dt = s.time() - m_lastTime;
      for (std::size_t k = 0; k < now.size(); ++k) m_integral[k] += 0.5 * (m_last[k] + now[k]) * dt;
      m_last = now;
      m_lastTime = s.time();
    }
    if (!due) return;
    if (m_mean && s.time() > m_windowStart) {
      std::vector<double> mean(now.size());
      for (std::size_t k = 0; k < now.size(); ++k) mean[k] = m_integral[k] / (s.time() - m_windowStart);
      m_series.add(s.time(), mean);
      m_integral.assign(now.size(), 0.0);
      m_windowStart = s.time();
    } else {
      m_series.add(s.time(), now);
    }
    while (m_interval > 0 && m_next <= s.time() * (1 + 1e-12)) m_next += m_interval;
  }
  bool empty() const { return m_series.names.empty(); }
  const ProbeSeries& series() const { return m_series; }

 private:
  ProbeSeries m_series;
  double m_interval, m_next;
  bool m_mean;
  std::vector<double> m_last, m_integral;  // the last step's readings; their integral over the window so far
  double m_lastTime = 0, m_windowStart = 0;
};

// Adds /probes to an existing, closed HDF5 file (SnapshotWriter's); replaces a /probes already there.
Status writeProbeSeries(const std::string& h5Path, const ProbeSeries& series);
Result<ProbeSeries> readProbeSeries(const std::string& h5Path);
// The same on an open file (hid_t), the caller holding hdf5Mutex(): /probes holds extendible (chunked) datasets,
// and appendProbeSeries adds `samples` at their end, creating them on the first call, and returns the samples now
// stored. The names must be the ones stored, in their order (INVALID_ARGUMENT otherwise); units and points are
// taken from the first call.
Result<std::uint64_t> appendProbeSeries(std::int64_t file, const ProbeSeries& samples, const std::string& pathForMessages);
Result<ProbeSeries> readProbeSeries(std::int64_t file, const std::string& pathForMessages);
// Samples [first, end) of a series (the part a worker has not sent yet).
ProbeSeries probeSamples(const ProbeSeries& series, std::size_t first);
// The CSV beside a snapshot file: out.h5 -> out.probes.csv.
std::string probesCsvPathFor(const std::string& h5Path);
// /probes into the closed snapshot file (writeProbeSeries) and the same series as CSV beside it.
Status writeProbeFiles(const std::string& h5Path, const ProbeSeries& series);
// `now` after the samples of the /probes already in h5Path from before its first time (a resumed run's earlier
// part), when that file has a series of the same names; else `now` alone.
ProbeSeries withEarlierSamples(const std::string& h5Path, const ProbeSeries& now);
// The /probes of a closed snapshot file as CSV beside it (probesCsvPathFor); nothing when it has none.
Status writeProbesCsv(const std::string& h5Path);
// "time,P1 [Pa],H1 [m]\n0,...": the CSV form.
std::string probeSeriesCsv(const ProbeSeries& series);

}  // namespace pflow::backend
