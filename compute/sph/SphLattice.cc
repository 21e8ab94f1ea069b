#include "compute/sph/SphLattice.h"

#include <cmath>

namespace pflow::compute::sph {
namespace {

int cellsAlong(double lo, double hi, double dp) { return std::max(0, int(std::floor((hi - lo) / dp + 1e-9))); }

void add(SphConfig& c, Vec3d x, ParticleKind kind, Vec3d v) {
  c.position.push_back(x);
  c.kind.push_back(kind);
  if (!c.velocity.empty() || v.x != 0 || v.y != 0 || v.z != 0) {
    c.velocity.resize(c.position.size() - 1, Vec3d{0, 0, 0});
    c.velocity.push_back(v);
  }
}

// Lattice points lo + (i + 1/2) dp for i in [from, to) per axis; the y range is one point at lo.y in 2D.
template <class F>
void lattice(const SphConfig& c, Vec3d lo, const int from[3], const int to[3], const F& f) {
  const double dp = c.spacing;
  const bool planar = c.dimension == 2;
  for (int k = from[2]; k < to[2]; ++k)
    for (int j = planar ? 0 : from[1]; j < (planar ? 1 : to[1]); ++j)
      for (int i = from[0]; i < to[0]; ++i) {
        const Vec3d x{lo.x + (i + 0.5) * dp, planar ? lo.y : lo.y + (j + 0.5) * dp, lo.z + (k + 0.5) * dp};
        f(x, i, j, k);
      }
}

}  // namespace

LatticeFill latticeFill(const SphConfig& c, Vec3d lo, Vec3d hi) {
  const bool planar = c.dimension == 2;
  LatticeFill f{{cellsAlong(lo.x, hi.x, c.spacing), planar ? 1 : cellsAlong(lo.y, hi.y, c.spacing), cellsAlong(lo.z, hi.z, c.spacing)}, {}, 0};
  f.filled = {f.count[0] * c.spacing, planar ? hi.y - lo.y : f.count[1] * c.spacing, f.count[2] * c.spacing};
  const double asked = (hi.x - lo.x) * (hi.z - lo.z) * (planar ? 1.0 : hi.y - lo.y);
  f.volumeFraction = asked > 0 ? f.filled.x * f.filled.z * (planar ? 1.0 : f.filled.y) / asked : 0.0;
  return f;
}

std::size_t addFluidBlock(SphConfig& c, const std::string& name, Vec3d lo, Vec3d hi, Vec3d velocity) {
  const std::size_t before = c.size();
  const int from[3] = {0, 0, 0};
  const LatticeFill fill = latticeFill(c, lo, hi);
  lattice(c, lo, from, fill.count, [&](Vec3d x, int, int, int) { add(c, x, ParticleKind::kFluid, velocity); });
  c.fluidBlocks.push_back({name, lo, hi});
  if (!c.velocity.empty()) c.velocity.resize(c.size(), Vec3d{0, 0, 0});
  return c.size() - before;
}

std::size_t addTank(SphConfig& c, const std::string& name, Vec3d lo, Vec3d hi, bool openTop, int layers) {
  const std::size_t before = c.size();
  if (layers <= 0) layers = std::max(1, int(std::ceil(2.0 * c.smoothingRatio - 1e-9)));
  const int n[3] = {cellsAlong(lo.x, hi.x, c.spacing), cellsAlong(lo.y, hi.y, c.spacing), cellsAlong(lo.z, hi.z, c.spacing)};
  const int from[3] = {-layers, -layers, -layers};
  const int to[3] = {n[0] + layers, n[1] + layers, n[2] + (openTop ? 0 : layers)};
  const bool planar = c.dimension == 2;
  lattice(c, lo, from, to, [&](Vec3d x, int i, int j, int k) {
    const bool inside = i >= 0 && i < n[0] && (planar || (j >= 0 && j < n[1])) && k >= 0 && k < n[2];
    if (!inside) add(c, x, ParticleKind::kBoundary, {0, 0, 0});
  });
  c.tank = SphRegion{name, lo, hi};
  c.tankOpenTop = openTop;
  if (!c.velocity.empty()) c.velocity.resize(c.size(), Vec3d{0, 0, 0});
  return c.size() - before;
}

void setMirrorTank(SphConfig& c, const std::string& name, Vec3d lo, Vec3d hi, bool openTop) {
  c.tank = SphRegion{name, lo, hi};
  c.tankOpenTop = openTop;
}

std::size_t addObstacle(SphConfig& c, const std::string& name, Vec3d lo, Vec3d hi) {
  const std::size_t before = c.size();
  const int from[3] = {0, 0, 0};
  const int to[3] = {cellsAlong(lo.x, hi.x, c.spacing), cellsAlong(lo.y, hi.y, c.spacing), cellsAlong(lo.z, hi.z, c.spacing)};
  lattice(c, lo, from, to, [&](Vec3d x, int, int, int) { add(c, x, ParticleKind::kBoundary, {0, 0, 0}); });
  c.obstacles.push_back({name, lo, hi});
  if (!c.velocity.empty()) c.velocity.resize(c.size(), Vec3d{0, 0, 0});
  return c.size() - before;
}

}  // namespace pflow::compute::sph
