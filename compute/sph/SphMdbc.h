// Modified dynamic boundary conditions (mDBC; English, Domínguez, Vacondio, Crespo, Stansby, Lind, Chiapponi &
// Gómez-Gesteira 2022, Comp. Part. Mech. 9, 1-15; sph.boundary_density: mdbc, docs/sph.md section 6): each boundary
// particle's density is not integrated from the continuity equation (the dynamic boundary, which keeps the fluid
// about an h off the wall and answers an impact with its own compression) but extrapolated from the fluid at its
// ghost node, its mirror image across the boundary's interface: at the ghost node g a first-order consistent
// interpolation gives the density and its gradient, and rho_b = rho_g + (x_b - x_g).grad rho_g. The geometry, the
// moments and their solve, as stateless PFLOW_HOSTDEVICE code; the pass over the boundary particles is
// SphMdbcKernels.h's.
#pragma once
#include <cmath>
#include <cstdint>

#include "compute/core/VectorMath.h"

namespace pflow::compute::sph {

// Where the boundary's interface lies, for the ghost nodes: the tank's inside (its walls' particles lie outside it)
// and the obstacles (boxes filled with boundary particles), as the lattice placed them (SphLattice.cc: whole
// spacings from each box's low corner, so an interface is at lo + n dp).
struct MdbcGeometry {
  static constexpr int kMaxObstacles = 8;
  bool on = false;
  bool planar = false;  // a 2D run: y is not an axis of the flow
  bool tank = false;     // the tank's walls are boundary particles (not mirrors)
  bool openTop = false;  // no lid: nothing beyond the tank's top is a wall
  Vec3d tankLo{0, 0, 0}, tankHi{0, 0, 0};
  int obstacles = 0;
  Vec3d obLo[kMaxObstacles] = {}, obHi[kMaxObstacles] = {};
  // Which faces of each obstacle face the fluid: a face lying on the tank's wall (the box stands on the floor) has
  // only wall behind it, and a ghost node across it would find none.
  std::uint8_t wetLo[kMaxObstacles] = {}, wetHi[kMaxObstacles] = {};  // bit a: the face normal to axis a
  double tie = 0;  // depths within this of each other are one (a particle on a box's diagonal) [m]

  // The ghost node of a boundary particle at x: false where x is neither in a tank's wall nor in an obstacle.
  // In an obstacle (looked at first): across the nearest face that meets the fluid, or across each of the nearest where
  // they tie. In a wall: across every face of the tank's inside it lies beyond (a corner particle through the corner).
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool ghost(const Vec3d& x, Vec3d& g) const {
    g = x;
    for (int k = 0; k < obstacles; ++k) {  // first: an obstacle may reach into the walls or above an open top
      bool inside = true;
      for (int a = 0; a < 3 && inside; ++a)
        if (!(planar && a == 1)) inside = (&x.x)[a] >= (&obLo[k].x)[a] && (&x.x)[a] <= (&obHi[k].x)[a];
      if (!inside) continue;
      double dLo[3], dHi[3], nearest = 1e300;
      for (int a = 0; a < 3; ++a) {
        const bool axis = !(planar && a == 1);
        dLo[a] = axis && (wetLo[k] >> a & 1) ? (&x.x)[a] - (&obLo[k].x)[a] : 1e300;
        dHi[a] = axis && (wetHi[k] >> a & 1) ? (&obHi[k].x)[a] - (&x.x)[a] : 1e300;
        nearest = fmin(nearest, fmin(dLo[a], dHi[a]));
      }
      if (nearest >= 1e299) return false;  // no face meets the fluid
      for (int a = 0; a < 3; ++a) {
        if (dLo[a] <= nearest + tie) (&g.x)[a] = 2 * (&obLo[k].x)[a] - (&x.x)[a];
        else if (dHi[a] <= nearest + tie) (&g.x)[a] = 2 * (&obHi[k].x)[a] - (&x.x)[a];
      }
      return true;
    }
    if (tank) {
      bool outside = false;
      for (int a = 0; a < 3; ++a) {
        if (planar && a == 1) continue;
        const double c = (&x.x)[a], lo = (&tankLo.x)[a], hi = (&tankHi.x)[a];
        if (c < lo) (&g.x)[a] = 2 * lo - c, outside = true;
        else if (c > hi && !(a == 2 && openTop)) (&g.x)[a] = 2 * hi - c, outside = true;
      }
      if (outside) return true;
    }
    return false;
  }
};

// The moments of the fluid around a ghost node g, in units of h (rt = (x_f - g)/h, Gt = h grad W): the corrected
// interpolation's matrix A and right-hand side b, with rho_f ~ rho_g + rt.(h grad rho)
//   A = sum_f V_f [W, W rt^T; Gt, Gt rt^T],  b = sum_f V_f rho_f [W; Gt]   (Liu & Liu 2006's first-order correction),
// summed in T (the run's precision: of order one in these units, so float keeps 1e-7 of them).
template <class T>
struct MdbcMoments {
  T a[4][4] = {};
  T b[4] = {};
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void add(const Vec3<T>& rt, T w, const Vec3<T>& gt, T volume, T rho) {
    const T u[4] = {w, gt.x, gt.y, gt.z};
    const T c[4] = {T(1), rt.x, rt.y, rt.z};
    for (int i = 0; i < 4; ++i) {
      const T vu = volume * u[i];
      for (int j = 0; j < 4; ++j) a[i][j] += vu * c[j];
      b[i] += vu * rho;
    }
  }
};

// Solves the moments' system over the axes in use (2D: 1, x and z) by Gaussian elimination with partial pivoting:
// rho_g and h grad rho_g in `u`. False when the fluid around g does not determine a gradient (|det A| < minDet: too
// little fluid, or all on one side of a plane).
template <class T>
PFLOW_HOSTDEVICE inline bool mdbcSolve(const MdbcMoments<T>& m, bool planar, double minDet, double u[4]) {
  const int idx[4] = {0, 1, 2, 3}, idx2[3] = {0, 1, 3};
  const int* use = planar ? idx2 : idx;
  const int n = planar ? 3 : 4;
  double a[4][5];
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) a[i][j] = double(m.a[use[i]][use[j]]);
    a[i][n] = double(m.b[use[i]]);
  }
  double det = 1;
  for (int col = 0; col < n; ++col) {
    int piv = col;
    for (int r = col + 1; r < n; ++r)
      if (fabs(a[r][col]) > fabs(a[piv][col])) piv = r;
    if (piv != col) {
      for (int j = 0; j <= n; ++j) {
        const double t = a[col][j];
        a[col][j] = a[piv][j];
        a[piv][j] = t;
      }
      det = -det;
    }
    det *= a[col][col];
    if (!(fabs(a[col][col]) > 1e-300)) return false;
    for (int r = col + 1; r < n; ++r) {
      const double f = a[r][col] / a[col][col];
      for (int j = col; j <= n; ++j) a[r][j] -= f * a[col][j];
    }
  }
  if (!(fabs(det) >= minDet)) return false;
  double x[4] = {0, 0, 0, 0};
  for (int i = n - 1; i >= 0; --i) {
    double s = a[i][n];
    for (int j = i + 1; j < n; ++j) s -= a[i][j] * x[j];
    x[i] = s / a[i][i];
  }
  for (int k = 0; k < 4; ++k) u[k] = 0;
  for (int i = 0; i < n; ++i) u[use[i]] = x[i];
  return true;
}

}  // namespace pflow::compute::sph
