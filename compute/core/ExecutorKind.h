// Which executor runs a solver's engine (every solver offers both).
#pragma once
#include <string>

#include "common/Status.h"

namespace pflow::compute {

// kAuto: the CUDA executor where a GPU is visible, else OpenMP. An explicit kCuda never falls back.
enum class ExecutorKind { kCpu, kCuda, kAuto };

// "cpu" | "cuda" | "auto" -> kind; an error naming the flag otherwise (compute/dem/Simulation.cc).
Result<ExecutorKind> parseExecutorKind(const std::string& name, const std::string& flag = "--executor");

// Usable CUDA devices: 0 without CUDA in the build, a driver or a GPU (compute/cuda).
int cudaDeviceCount();
bool cudaBuiltIn();

}  // namespace pflow::compute
