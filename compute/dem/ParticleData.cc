#include "compute/dem/ParticleData.h"

namespace pflow::compute {

template class FieldStore<DemFieldSet, float>;
template class FieldStore<DemFieldSet, double>;

}  // namespace pflow::compute
