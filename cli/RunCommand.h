// `pflow run` and `pflow validate`: a scene file run in this process, snapshots to one HDF5 file.
#pragma once
#include <cstdint>
#include <string>

#include <memory>

#include "common/Status.h"

namespace pflow::backend {
class SnapshotWriter;
}

namespace pflow::cli {

struct RunOptions {
  std::string scenePath;
  std::string outputPath;      // empty: the scene's output.file, else <scene stem>.h5 beside the scene
  std::string executor = "auto";  // auto | cpu | cuda
  int device = 0;                  // CUDA device index
  int threads = 0;             // 0: the scene's, else all cores
  double progressSeconds = 2;  // progress line interval (wall clock); 0 = none
  bool json = false;           // print the summary as one JSON object on stdout
  std::int64_t maxSteps = -1;  // stop after this many steps (< 0: run the whole duration)
  bool initialOnly = false;    // write the initial state (/snapshots/0 and /geometry) and stop: `pflow build`
  // Checkpoints (docs/operations.md): one at the first neighbour rebuild after every checkpointEvery steps (0:
  // none) into checkpointPath (empty: OUT.ckpt.h5 beside the output), the one before kept as PATH.1; resumePath:
  // go on from a checkpoint (the scene is the one it holds; the output must be named).
  std::int64_t checkpointEvery = 0;
  double checkpointWallSeconds = 600;  // and when this much wall-clock time has passed since the last (0: never)
  std::string checkpointPath;
  std::string resumePath;
};

struct RunSummary {
  std::string outputPath;
  std::string xdmfPath;
  std::int64_t steps = 0;
  double simulatedTime = 0;    // [s]
  double wallSeconds = 0;
  double particleStepsPerSecond = 0;
  std::size_t particles = 0;
  std::size_t snapshots = 0;
  std::string executor;
};

// Exit codes: 0 ok, 1 invalid scene or options, 2 I/O failure, 3 the simulation failed (e.g. went
// non-finite: the message names the particle, step and quantity).
// Cluster commands add: 4 a service is unreachable, 5 refused (too few free devices with --no-wait), 6 the watched
// job was cancelled (a failed job gives 3).
enum ExitCode { kExitOk = 0, kExitInvalid = 1, kExitIo = 2, kExitSimulation = 3, kExitUnavailable = 4, kExitRefused = 5, kExitCancelled = 6, kExitDenied = 7 };

Result<RunSummary> runScene(const RunOptions& options);
// "42.0 s", "3.5 min", "2.1 h": a duration for a progress line (every solver's driver).
std::string humanSeconds(double seconds);
// The output file's folder created and its snapshot writer opened (every solver's driver).
Result<std::unique_ptr<backend::SnapshotWriter>> openOutput(const std::string& path);
int exitCodeFor(const Status& s);

// Prints the scene's errors (all of them) or a summary; returns 0 when valid.
int validateScene(const std::string& scenePath, bool json);

}  // namespace pflow::cli
