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

// Adds /probes to an existing, closed HDF5 file (SnapshotWriter's); replaces a /probes already there.
Status writeProbeSeries(const std::string& h5Path, const ProbeSeries& series);
Result<ProbeSeries> readProbeSeries(const std::string& h5Path);
// The same on an open file (hid_t), the caller holding hdf5Mutex(): /probes holds extendible (chunked) datasets,
// and appendProbeSeries adds `samples` at their end, creating them on the first call. The names must be the ones
// stored, in their order (INVALID_ARGUMENT otherwise); units and points are taken from the first call.
Status appendProbeSeries(std::int64_t file, const ProbeSeries& samples, const std::string& pathForMessages);
Result<ProbeSeries> readProbeSeries(std::int64_t file, const std::string& pathForMessages);
// Samples [first, end) of a series (the part a worker has not sent yet).
ProbeSeries probeSamples(const ProbeSeries& series, std::size_t first);
// "time,P1 [Pa],H1 [m]\n0,...": the CSV form.
std::string probeSeriesCsv(const ProbeSeries& series);

}  // namespace pflow::backend
