// Device-side error and capacity flags, written by kernels with atomics and read by the host once
// per phase (HOOMD d_conditions). Kernels never print and never drop data silently.
#pragma once
#include <cstdint>

#include "compute/core/Types.h"

namespace pflow::compute {

enum ConditionBits : std::uint32_t {
  kNeighborMismatch = 1u << 0,      // a candidate walk's filling pass (particles or triangles) found another count than its counting pass
  kHistoryOverflow = 1u << 1,       // a particle has more contacts than history slots
  kWallHistoryOverflow = 1u << 2,   // a particle has more wall contacts than wall slots
  kNonFinite = 1u << 4,             // a position, velocity, spin, force or torque is NaN or infinite
  kTooManyWallContacts = 1u << 5,   // more simultaneous triangle contacts than kMaxWallContacts
  kExcessiveOverlap = 1u << 6,      // an overlap beyond the run's limit (simulation.max_overlap): blow-up
  kTunnelled = 1u << 7,             // a centre behind a plane, or carried through a triangle's face
  kLeftDomain = 1u << 8,            // a centre outside the scene's explicit simulation.domain (SPH: outside the tank's walls)
  kDensityOutOfRange = 1u << 9,     // SPH: a fluid particle's density outside the run's bounds (sph.density_bounds)
};

struct Conditions {
  std::uint32_t flags = 0;
  std::uint32_t neededHistory = 0;       // largest contact count seen
  std::uint32_t neededWallHistory = 0;   // largest wall-contact count seen
  std::uint32_t badParticle = kNoIndex;  // lowest local index with a non-finite value (the host names the quantity)
  std::uint32_t deepParticle = kNoIndex; // lowest local index with an excessive overlap
  std::uint32_t tunnelParticle = kNoIndex;  // lowest local index that tunnelled through a wall
  std::uint32_t outsideParticle = kNoIndex; // lowest local index outside the explicit domain
  std::uint32_t densityParticle = kNoIndex; // SPH: lowest local index with a density out of range
};

namespace kernels {
// Resets the flags on the device: a launch queued behind the previous phase, not a host copy that
// would wait for it.
struct ResetConditions {
  Conditions* cond;
  PFLOW_HOSTDEVICE void operator()(Index) const { *cond = Conditions{}; }
};
}  // namespace kernels

}  // namespace pflow::compute
