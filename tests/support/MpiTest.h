// What the MPI test programs (tests/mpi, main in mpi_test_main.cc) share: which executor their simulations run
// on and, on the GPU, which device a rank takes.
#pragma once
#include <cstdlib>
#include <string>

#include "compute/core/ExecutorKind.h"

namespace pflow::test {

// This rank's index among the ranks on its node (compute::nodeRanks, taken once by main after MPI_Init).
int nodeRank();

// PFLOW_TEST_EXECUTOR=cuda runs the simulations on the GPU (the one-process references included); otherwise the CPU.
inline compute::ExecutorKind testExecutor() {
  const char* e = std::getenv("PFLOW_TEST_EXECUTOR");
  return e && std::string(e) == "cuda" ? compute::ExecutorKind::kCuda : compute::ExecutorKind::kCpu;
}
// The GPU of this rank: its node index modulo the node's devices (one rank a GPU where there are enough).
inline int testDevice() {
  const int gpus = compute::cudaDeviceCount();
  return gpus > 0 ? nodeRank() % gpus : 0;
}

}  // namespace pflow::test
