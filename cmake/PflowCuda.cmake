# CUDA is optional: built when nvcc is found (sm_90 + PTX), the CPU build works without it.
set(PFLOW_HAVE_CUDA OFF)
if(PFLOW_ENABLE_CUDA)
  include(CheckLanguage)
  if(NOT CMAKE_CUDA_COMPILER AND EXISTS /usr/local/cuda/bin/nvcc)
    set(CMAKE_CUDA_COMPILER /usr/local/cuda/bin/nvcc)
  endif()
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
      # sm_90 SASS plus compute_90 PTX so newer GPUs can JIT it.
      set(CMAKE_CUDA_ARCHITECTURES 90-real 90-virtual)
    endif()
    enable_language(CUDA)
    # The engine (EngineImpl.h) is instantiated in .cu files, so CUDA sources are C++20 like the rest.
    # CMake 3.25 knows no CUDA20 dialect flag for nvcc 13 (CUDA_STANDARD 20 fails to generate): teach it.
    set(CMAKE_CUDA20_STANDARD_COMPILE_OPTION "-std=c++20")
    set(CMAKE_CUDA20_EXTENSION_COMPILE_OPTION "-std=c++20")
    set(CMAKE_CUDA_STANDARD 20)
    set(CMAKE_CUDA_STANDARD_REQUIRED ON)
    find_package(CUDAToolkit REQUIRED)
    # Line tables in the device code (no change to the machine code): Nsight Compute's source page maps its
    # per-instruction counters to the lines of the kernels (bench/gpu/profile_rates.sh).
    string(APPEND CMAKE_CUDA_FLAGS " -lineinfo")
    set(PFLOW_HAVE_CUDA ON)
    message(STATUS "pflow: CUDA enabled (${CMAKE_CUDA_COMPILER}, archs ${CMAKE_CUDA_ARCHITECTURES})")
  else()
    message(STATUS "pflow: nvcc not found, building the CPU executor only")
  endif()
endif()
