#include "compute/worker/WorkerRun.h"

#include <mpi.h>

#include <csignal>
#include <cstdio>

namespace pflow::worker {

volatile std::sig_atomic_t g_stopSignal = 0;

RankPlacement placeRank(const WorkerOptions& o, int rank, int ranks, const compute::RunConfig& config) {
  RankPlacement p;
  const LeasedDevice& device = o.devices[std::size_t(rank)];
  if (device.kind == "gpu") {
    p.executor = compute::ExecutorKind::kCuda;
    p.device = device.index;
  }
  compute::MpiDomainOptions split;
  split.strategy = config.sim.decomposition;
  if (ranks > 1) p.domain = std::make_shared<compute::MpiDomain>(MPI_COMM_WORLD, split);
  return p;
}

int stopAgreed(bool cancelRequested, const std::shared_ptr<compute::MpiDomain>& domain) {
  int stop = (g_stopSignal ? kStopSignal : 0) | (cancelRequested ? kStopCancel : 0);
  if (domain) MPI_Allreduce(MPI_IN_PLACE, &stop, 1, MPI_INT, MPI_BOR, MPI_COMM_WORLD);  // every rank stops together
  return stop;
}

int stoppedExitCode(int why) {
  if (why & kStopCancel) return 0;
  spdlog::warn("stopped by a signal the manager did not ask for: exit code {} (the job goes on from its checkpoint)", 128 + SIGTERM);
  return 128 + SIGTERM;
}

int fail(int code, const std::string& message) {
  spdlog::error("{}", message);
  std::fprintf(stderr, "%s\n", message.c_str());  // the agent reports the last stderr line
  return code;
}

}  // namespace pflow::worker
