#include "compute/core/CpuExecutor.h"
#include "compute/sph/SphEngineImpl.h"

namespace pflow::compute::sph {

template class SphEngineImpl<CpuExecutor, double>;
template class SphEngineImpl<CpuExecutor, float>;

std::unique_ptr<SphEngine> makeCpuSphEngine(SphSetup setup, bool singlePrecision) {
  if (singlePrecision) return std::make_unique<SphEngineImpl<CpuExecutor, float>>(std::move(setup));
  return std::make_unique<SphEngineImpl<CpuExecutor, double>>(std::move(setup));
}

}  // namespace pflow::compute::sph
