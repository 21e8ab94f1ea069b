// libFuzzer target for the scene loader: any byte string must give a scene or a list of errors, never a crash,
// a hang or a sanitizer report. Built with clang only (cmake -DPFLOW_BUILD_FUZZ=ON, see deploy/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <string>

#include "frontend/SceneLoader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string yaml(reinterpret_cast<const char*>(data), size);
  pflow::frontend::LoadOptions options;
  options.baseDir = "/nonexistent-pflow-fuzz";  // file references fail cleanly
  options.maxParticles = 20000;                 // keep each input fast
  options.maxTriangles = 20000;
  options.maxLatticeSites = 2'000'000;          // a thin region in huge bounds stops instead of timing out
  auto scene = pflow::frontend::loadSceneFromString(yaml, "<fuzz>", options);
  if (scene) {
    volatile std::size_t n = scene.value().config.particles.size();
    (void)n;
  }
  return 0;
}
