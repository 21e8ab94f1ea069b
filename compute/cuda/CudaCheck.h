// Checks of CUDA runtime calls: a failed call is a bug or an exhausted device, never ignored.
// CudaError carries the call, the file and line, and the runtime's message.
#pragma once
#include <cuda_runtime.h>

#include <stdexcept>
#include <string>

namespace pflow::compute::cuda {

class CudaError : public std::runtime_error {
 public:
  CudaError(cudaError_t code, const char* what, const char* file, int line)
      : std::runtime_error(std::string("CUDA error: ") + cudaGetErrorString(code) + " (" + cudaGetErrorName(code) +
                           ") in " + what + " at " + file + ":" + std::to_string(line)),
        m_code(code) {}
  cudaError_t code() const { return m_code; }

 private:
  cudaError_t m_code;
};

inline void check(cudaError_t e, const char* what, const char* file, int line) {
  if (e != cudaSuccess) throw CudaError(e, what, file, line);
}

}  // namespace pflow::compute::cuda

#define PFLOW_CUDA_CHECK(call) ::pflow::compute::cuda::check((call), #call, __FILE__, __LINE__)
