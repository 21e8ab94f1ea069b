#include "compute/core/CpuExecutor.h"
#include "compute/sim/EngineImpl.h"

namespace pflow::compute {

template class EngineImpl<CpuExecutor>;

std::unique_ptr<Engine> makeCpuEngine(EngineSetup setup) {
  return std::make_unique<EngineImpl<CpuExecutor>>(std::move(setup));
}

}  // namespace pflow::compute
