// The DEM solver's particle state: the generic field store (FieldStore.h) over the DEM field table.
#pragma once
#include "compute/particles/FieldStore.h"
#include "compute/dem/ParticleFields.h"

namespace pflow::compute {

template <class R>
using ParticleData = FieldStore<DemFieldSet, R>;

extern template class FieldStore<DemFieldSet, float>;
extern template class FieldStore<DemFieldSet, double>;

}  // namespace pflow::compute
