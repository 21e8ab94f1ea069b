#include "compute/core/CpuExecutor.h"
#include "compute/dem/EngineImpl.h"

namespace pflow::compute {

template class EngineImpl<CpuExecutor, double>;
template class EngineImpl<CpuExecutor, float>;

std::unique_ptr<Engine> makeCpuEngine(EngineSetup setup, bool singlePrecision) {
  if (singlePrecision) return std::make_unique<EngineImpl<CpuExecutor, float>>(std::move(setup));
  return std::make_unique<EngineImpl<CpuExecutor, double>>(std::move(setup));
}

}  // namespace pflow::compute
