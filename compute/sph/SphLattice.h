// SPH particles on a lattice of spacing dp: fluid blocks, a tank's walls as layers of boundary particles and
// solid obstacles (docs/sph.md, "Initial particles"). Used by the scene loader (solver: sph) and by tests and
// benchmarks that build scenes in code. Host code.
#pragma once
#include <string>

#include "compute/sph/SphConfig.h"

namespace pflow::compute::sph {

// Fluid particles at lo + (k + 1/2) dp inside [lo, hi] (2D: in the plane y = lo.y), at velocity v; the block
// is recorded in config.fluidBlocks under `name`. Returns the particles added.
std::size_t addFluidBlock(SphConfig& config, const std::string& name, Vec3d lo, Vec3d hi, Vec3d velocity = {0, 0, 0});

// What a block [lo, hi] is filled as (addFluidBlock's rule): whole spacings from its low corner along each axis, so
// a side that is not a multiple of dp comes out short by up to one spacing. `count`: the particles along x, y, z
// (y: 1 in 2D); `filled`: count x dp [m] (y: the block's own width in 2D); `volumeFraction`: the filled volume (2D:
// area) over the block's.
struct LatticeFill {
  int count[3];
  Vec3d filled;
  double volumeFraction;
  std::size_t particles() const { return std::size_t(count[0]) * std::size_t(count[1]) * std::size_t(count[2]); }
};
LatticeFill latticeFill(const SphConfig& config, Vec3d lo, Vec3d hi);

// The walls of a box tank whose inside is [lo, hi]: `layers` layers of boundary particles (0: derived,
// ceil(2h/dp)) outside the floor and the side walls (2D: left and right), up to hi.z, and over the top
// unless `openTop`. Recorded as config.tank.
std::size_t addTank(SphConfig& config, const std::string& name, Vec3d lo, Vec3d hi, bool openTop = true, int layers = 0);
// A tank of mirror walls (sph.boundary: mirror): recorded as config.tank, no particles.
void setMirrorTank(SphConfig& config, const std::string& name, Vec3d lo, Vec3d hi, bool openTop = true);

// A solid box [lo, hi] filled with boundary particles (a wall as thick as the box). Recorded in config.obstacles.
std::size_t addObstacle(SphConfig& config, const std::string& name, Vec3d lo, Vec3d hi);

}  // namespace pflow::compute::sph
