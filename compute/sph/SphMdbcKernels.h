// The modified dynamic boundary's pass (sph.boundary_density: mdbc; SphMdbc.h has the geometry, the moments and their
// solve, docs/sph.md section 6): one boundary particle per call, run by either executor.
#pragma once
#include <cmath>
#include <cstdint>

#include "compute/neighbor/CellGrid.h"
#include "compute/sph/SphKernels.h"
#include "compute/sph/SphMdbc.h"
#include "compute/sph/SphPhysics.h"

namespace pflow::compute::sph {

namespace kernels {

// The boundary particles' density (and pressure) from the fluid at their ghost nodes, before each evaluation of the
// rates: one call per item of `list`, the boundary particles with fluid listed within reach at the last sort (MarkWet;
// the others cannot be seen by any fluid particle and keep their density), over the fluid in the rows of cells around
// the ghost node (the probes' rows along x), less the rows and end cells that lie beyond the support even with their
// particles moved `margin` out of them (walkGap, as the rates pass prunes). A particle without a ghost node keeps its
// density. Where the fluid around the ghost node does not determine a gradient (|det A| < 1e-3), the Shepard density
// there; where the fluid's kernel share there is under 0.05, rho0. Never below rho0 (a wall must not pull fluid, as
// for the dynamic boundary) nor above the fluid's upper density bound (sph.density_bounds). The moments in R (float
// runs: float), the solve in double. Mirror walls' images are not among the fluid summed: a ghost node near a mirror
// sees the fluid's side of it only.
template <class R>
struct MdbcDensity {
  static constexpr bool kVariableCost = true;
  static constexpr double kMinDet = 1e-3, kMinShare = 0.05;
  CellGrid grid;
  const Index* cellStart;
  const Vec3d* pos;
  const std::int32_t* kind;
  const R* mass;
  const Index* list;
  Kernel<R> kernel;
  Tait<R> eos;
  MdbcGeometry geometry;
  double rho0, rhoMax;  // the bounds of a boundary particle's density: rho0 and the fluid's upper bound
  double margin;  // [m]: how far a particle may be from the cell it is listed in (half the skin, widened)
  R* rho;
  R* p;

  PFLOW_HOSTDEVICE void operator()(Index item) const {
    const Index i = list[item];
    const Vec3d x = pos[i];
    Vec3d g;
    if (!geometry.ghost(x, g)) return;
    const R h = kernel.h, invH = kernel.invH;
    const double support = double(kernel.support()), reach2 = support * support;
    const R cut2 = kernel.support() * kernel.support();
    MdbcMoments<R> m;
    int cx, cy, cz;
    grid.coords(g, cx, cy, cz);
    const int r = grid.reach;
    const double cs = grid.cellSize;
    // g's offset from the low corner of its cell, per axis (walkGap's o).
    const Vec3d o = g - (grid.lo + cs * Vec3d{double(cx), double(cy), double(cz)});
    for (int z = cz > r ? cz - r : 0; z <= (cz + r < grid.nz ? cz + r : grid.nz - 1); ++z) {
      const double gz = walkGap(o.z, z - cz, cs, margin, z == 0, z == grid.nz - 1);
      if (gz * gz >= reach2) continue;
      for (int y = cy > r ? cy - r : 0; y <= (cy + r < grid.ny ? cy + r : grid.ny - 1); ++y) {
        const double gy = walkGap(o.y, y - cy, cs, margin, y == 0, y == grid.ny - 1), g2 = gz * gz + gy * gy;
        if (g2 >= reach2) continue;
        int x0 = cx > r ? cx - r : 0, x1 = cx + r < grid.nx ? cx + r : grid.nx - 1;
        while (x0 < cx && [&] { const double e = walkGap(o.x, x0 - cx, cs, margin, x0 == 0, false); return g2 + e * e >= reach2; }()) ++x0;
        while (x1 > cx && [&] { const double e = walkGap(o.x, x1 - cx, cs, margin, false, x1 == grid.nx - 1); return g2 + e * e >= reach2; }()) --x1;
        for (Index b = cellStart[grid.index(x0, y, z)]; b < cellStart[grid.index(x1, y, z) + 1]; ++b) {
          if (kind[b] != 0) continue;
          const Vec3<R> d = vcast<R>(pos[b] - g);
          const R r2 = norm2(d);
          if (r2 >= cut2) continue;
          const R dist = std::sqrt(r2);
          const R rhoB = rho[b];
          // grad_g W(g - x_b) = f (g - x_b): in units of h, -h f d.
          m.add(invH * d, kernel.w(dist), (-h * kernel.f(dist)) * d, mass[b] / rhoB, rhoB);
        }
      }
    }
    double u[4];
    double out;
    if (mdbcSolve(m, geometry.planar, kMinDet, u)) {
      const Vec3d s = (1.0 / double(h)) * (x - g);
      out = u[0] + u[1] * s.x + u[2] * s.y + u[3] * s.z;
    } else if (double(m.a[0][0]) >= kMinShare) {
      out = double(m.b[0]) / double(m.a[0][0]);
    } else {
      out = rho0;
    }
    if (!(out >= rho0)) out = rho0;  // also a NaN
    if (out > rhoMax) out = rhoMax;  // an extrapolation past what the fluid may reach
    rho[i] = R(out);
    p[i] = eos.pressure(R(out));
  }
};

// The boundary particles the mDBC pass updates (flag 1): those with fluid listed within reach at the last sort.
struct MdbcFlag {
  const std::int32_t* kind;
  const std::uint8_t* wet;
  std::uint32_t* flag;
  PFLOW_HOSTDEVICE void operator()(Index i) const { flag[i] = kind[i] != 0 && wet[i] ? 1u : 0u; }
};

}  // namespace kernels
}  // namespace pflow::compute::sph
