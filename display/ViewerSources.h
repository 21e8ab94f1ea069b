// What the web viewer (pflow-web) asks of the manager and the back-end, always on behalf of the user whose token it
// was handed: the services decide what that user may see (docs/security.md). GrpcViewerSources.cc is the real one,
// over gRPC with the viewer's own certificate; tests of the HTTP side may use fakes. Every call has a deadline.
#pragma once
#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"

namespace pflow::display {

// Jobs and nodes as JSON (manager/JobJson.h: the CLI's `--json` shapes).
class JobSource {
 public:
  virtual ~JobSource() = default;
  virtual Result<nlohmann::json> listJobs(const std::string& token, bool all) = 0;
  virtual Result<nlohmann::json> getJob(const std::string& token, const std::string& id) = 0;
  virtual Result<nlohmann::json> cancelJob(const std::string& token, const std::string& id) = 0;
  virtual Result<nlohmann::json> listNodes(const std::string& token) = 0;
  // The job now, then each change, to `onEvent` (JobJson's event), until the job ends, `onEvent` returns false or
  // `keepGoing` says stop (checked between events).
  virtual Status watchJob(const std::string& token, const std::string& id, const std::function<bool(const nlohmann::json&)>& onEvent) = 0;
};

// One piece of a snapshot array, its values as float32 (what a browser draws; ids and kinds fit a float exactly up
// to 2^24).
// The grid a grid array lies on (backend/fields/GridFields.h): cubic cells, cell (i, j, k) at row i.
struct GridInfo {
  double origin[3] = {0, 0, 0};  // m, lower corner of cell (0, 0, 0)
  double cellSize = 0;           // m
  std::uint32_t cells[3] = {0, 0, 0};
};

struct ArrayPiece {
  std::string section;  // "particles", "grid", "geometry", "probes"
  std::string name;     // "position", "velocity", "solid_fraction", ...
  std::uint64_t rows = 0, firstRow = 0, totalRows = 0, components = 1;
  std::string unit;     // SI, "" = dimensionless
  std::vector<float> values;  // rows x components
  std::optional<GridInfo> grid;       // grid arrays: their grid
  std::vector<std::string> strings;   // a list of names (geometry's surface names) instead of values
};

struct SnapshotRequest {
  std::string job;
  std::optional<std::int64_t> step;  // unset: the last
  std::vector<std::string> fields;   // empty: every particle field
  bool grid = false, geometry = false;
  bool probes = false;    // the run's time series (section "probes": "time", then one array per series)
  bool particles = true;  // false: no particle arrays (the series alone)
};

class SnapshotSource {
 public:
  virtual ~SnapshotSource() = default;
  // {"file": ..., "snapshots": [{"step", "time", "particles"}]}.
  virtual Result<nlohmann::json> listSnapshots(const std::string& token, const std::string& job) = 0;
  // The snapshot's arrays piece by piece (each at most 1 MiB of values), in the back-end's order; `step` and `time`
  // of the snapshot first. Stops early when `onPiece` returns false.
  virtual Status readSnapshot(const std::string& token, const SnapshotRequest& request,
                              const std::function<void(std::int64_t step, double time)>& onHeader,
                              const std::function<bool(const ArrayPiece&)>& onPiece) = 0;
};

// The manager at `managerAddress` and the back-end at `backendAddress`, over the process's transport (Transport.h).
std::unique_ptr<JobSource> makeGrpcJobSource(const std::string& managerAddress);
std::unique_ptr<SnapshotSource> makeGrpcSnapshotSource(const std::string& backendAddress);

}  // namespace pflow::display
