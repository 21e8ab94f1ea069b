// The compute worker's command line, as the node agent builds it (manager/agent/README.md):
//   pflow-worker --job-id ID --model DIR --manager HOST:PORT --backend HOST:PORT --devices node:kind:index,...
// One MPI rank per leased device; rank r uses the r-th entry of --devices.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/Status.h"

namespace pflow::worker {

struct LeasedDevice {
  std::string node;
  std::string kind;  // "gpu" or "cpu"
  int index = 0;
};

struct WorkerOptions {
  std::string jobId;
  std::string modelDir;          // the built model: scene.yaml and its files
  std::string managerAddress;    // empty: no progress reports (standalone)
  std::string backendAddress;    // empty: snapshots to --output instead
  std::string output;            // local HDF5 file when no back-end is given
  std::vector<LeasedDevice> devices;
  double progressInterval = 1.0;  // [s] wall clock between progress reports
  int threads = 0;               // OpenMP threads per rank; 0 = all cores / ranks on this node
  // Output the back-end could not take yet, kept in order (SpoolingSink): at most this many bytes before output
  // pauses; at the end, how long to wait for the back-end before the job fails.
  double spoolBytes = double(std::uint64_t(1) << 30);
  double spoolCloseWait = 600;  // [s]
  // Checkpoints to the back-end (JobCheckpoints.h): every this many seconds of wall clock (0: only the scene's
  // output.checkpoint_interval); --resume: go on from the job's last checkpoint (the agent passes it on a requeue).
  double checkpointWallSeconds = 600;
  bool resume = false;
  int attempt = 1;  // the job's attempt (the lease's): sent with progress, so a worker of an earlier one is told to stop
};

// "node:gpu:0,node:cpu:1" -> devices; errors name the entry.
Result<std::vector<LeasedDevice>> parseDevices(const std::string& list);

// Under Slurm (--devices slurm:gpu or slurm:cpu; the manager's --placement slurm): this rank's device from the
// environment srun gives each task: the node SLURMD_NODENAME; a GPU task's device is the one GPU Slurm made visible
// to it (index 0 when CUDA_VISIBLE_DEVICES names exactly one), else its SLURM_LOCALID-th; a CPU task's slot its
// SLURM_LOCALID. `env` looks a variable up (nullptr when unset). INVALID_ARGUMENT outside srun.
Result<LeasedDevice> slurmDevice(const std::string& kind, const char* (*env)(const char*));

}  // namespace pflow::worker
