// Triangle walls: prescribed rigid motion, binning into the particle cell grid, and per-particle
// candidate triangles (within r + skin at rebuild time).
#pragma once
#include <cmath>
#include <cstdint>

#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/geometry/TriangleGeometry.h"
#include "compute/neighbor/CellGrid.h"

namespace pflow::compute {

// Device copy of a mesh's prescribed motion (see MeshMotion in RunConfig.h).
// A mesh's prescribed motion (RunConfig's MeshMotion): from startTime, a constant velocity plus a sinusoidal
// vibration carry the rotation axis, about which the mesh turns at a constant angular speed.
struct MeshMotionParams {
  Vec3d velocity;
  Vec3d axisPoint;  // at startTime
  Vec3d axis;       // unit
  double angularSpeed;
  double startTime;
  Vec3d vibration;    // amplitude [m]; zero: none
  double omega;       // vibration's angular frequency 2 pi f [rad/s]
  double phase;       // [rad]
  // A piecewise-linear translation velocity in place of `velocity` (profilePoints >= 1): points (tau, v).
  int profilePoints;
  double profileTau[kMaxProfilePoints];
  Vec3d profileVelocity[kMaxProfilePoints];
  // A driven wall (compute/dem/WallDrive.h) over one step: where it was at startTime (its axis point moved by
  // `offset`, turned by `angle0`), then `velocity` and `angularSpeed`; 0 for every other mesh.
  Vec3d offset;
  double angle0;

  PFLOW_HOSTDEVICE double elapsed(double t) const { return t > startTime ? t - startTime : 0.0; }
  // The profile's velocity at tau, and its integral from 0 to tau (exact: trapezoids, and a partial one).
  PFLOW_HOSTDEVICE Vec3d profileAt(double tau) const {
    const int n = profilePoints;
    if (tau <= profileTau[0]) return profileVelocity[0];
    for (int k = 0; k + 1 < n; ++k)
      if (tau < profileTau[k + 1]) {
        const double f = (tau - profileTau[k]) / (profileTau[k + 1] - profileTau[k]);
        return profileVelocity[k] + f * (profileVelocity[k + 1] - profileVelocity[k]);
      }
    return profileVelocity[n - 1];
  }
  PFLOW_HOSTDEVICE Vec3d profileDisplacement(double tau) const {
    const int n = profilePoints;
    const double first = tau < profileTau[0] ? tau : profileTau[0];
    Vec3d d = first * profileVelocity[0];  // constant before the first point
    for (int k = 0; k + 1 < n && tau > profileTau[k]; ++k) {
      const double b = tau < profileTau[k + 1] ? tau : profileTau[k + 1];
      d = d + (0.5 * (b - profileTau[k])) * (profileVelocity[k] + profileAt(b));
    }
    if (tau > profileTau[n - 1]) d = d + (tau - profileTau[n - 1]) * profileVelocity[n - 1];
    return d;
  }
  // The translation after tau of motion: velocity tau (or the profile's integral) + A (sin(omega tau + phase) -
  // sin(phase)).
  PFLOW_HOSTDEVICE Vec3d translation(double tau) const {
    Vec3d d = profilePoints > 0 ? profileDisplacement(tau) : tau * velocity;
    if (omega != 0.0) d = d + (std::sin(omega * tau + phase) - std::sin(phase)) * vibration;
    return d;
  }
  PFLOW_HOSTDEVICE Vec3d translationVelocity(double tau) const { return profilePoints > 0 ? profileAt(tau) : velocity; }
  // Position at time t of a point that was at x0 before the motion started.
  PFLOW_HOSTDEVICE Vec3d transform(Vec3d x0, double t) const {
    const double tau = elapsed(t);
    const double angle = angle0 + angularSpeed * tau;
    const Vec3d r = angle != 0.0 ? rotateAbout(x0 - axisPoint, axis, angle) : x0 - axisPoint;
    return axisPoint + offset + translation(tau) + r;
  }
  // Velocity at time t of the mesh point currently at x.
  PFLOW_HOSTDEVICE Vec3d velocityAt(Vec3d x, double t) const {
    if (t <= startTime) return zero3<double>();
    const double tau = elapsed(t);
    const Vec3d c = axisPoint + offset + translation(tau);
    Vec3d v = translationVelocity(tau) + cross(angularSpeed * axis, x - c);
    if (omega != 0.0) v = v + (omega * std::cos(omega * tau + phase)) * vibration;
    return v;
  }
};

struct PlaneParams {
  Vec3d point;
  Vec3d normal;  // unit, towards the particles
  std::int32_t material;
};

// Wall keys (tangential-history slots of wall contacts): planes have the top bit set; triangles carry their mesh in the upper word.
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint64_t planeKey(Index p) { return (std::uint64_t(1) << 63) | p; }
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint64_t triangleKey(std::int32_t mesh, Index t) {
  return (std::uint64_t(std::uint32_t(mesh)) << 32) | t;
}
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool sameMesh(std::uint64_t a, std::uint64_t b) {
  return !(a >> 63) && !(b >> 63) && (a >> 32) == (b >> 32);
}

inline constexpr int kMaxPlanes = 32;  // planes are selected per particle through a 32-bit mask

namespace kernels {

// Moves triangle vertices (3 per triangle, triangle soup) to time t; returns the squared
// displacement since the last rebuild.
struct MoveTriangles {
  const Vec3d* refVerts;      // at t <= startTime
  Vec3d* verts;               // current
  const Vec3d* rebuildVerts;  // at the last rebuild
  const std::int32_t* triMesh;
  const MeshMotionParams* motion;
  double time;
  const Index* which = nullptr;  // the triangles moved (k-th: which[k]); null: all
  PFLOW_HOSTDEVICE double operator()(Index k) const {
    const Index t = which ? which[k] : k;
    const MeshMotionParams& m = motion[triMesh[t]];
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec3d v = m.transform(refVerts[3 * t + k], time);
      verts[3 * t + k] = v;
      const double dk = norm2(v - rebuildVerts[3 * t + k]);
      d2 = dk > d2 ? dk : d2;
    }
    return d2;
  }
};

// Cell range of a triangle's bounding box inflated by `margin`.
PFLOW_HOSTDEVICE inline void triangleCellRange(const CellGrid& g, const Vec3d* v, double margin, int lo[3], int hi[3]) {
  Vec3d mn = v[0], mx = v[0];
  for (int k = 1; k < 3; ++k) {
    mn.x = std::fmin(mn.x, v[k].x); mn.y = std::fmin(mn.y, v[k].y); mn.z = std::fmin(mn.z, v[k].z);
    mx.x = std::fmax(mx.x, v[k].x); mx.y = std::fmax(mx.y, v[k].y); mx.z = std::fmax(mx.z, v[k].z);
  }
  g.coords({mn.x - margin, mn.y - margin, mn.z - margin}, lo[0], lo[1], lo[2]);
  g.coords({mx.x + margin, mx.y + margin, mx.z + margin}, hi[0], hi[1], hi[2]);
}

// Pass 1: count triangles per cell. Pass 2 (fill = true): write them at binStart[c] + cursor[c].
struct BinTriangles {
  CellGrid grid;
  const Vec3d* verts;
  double margin;
  std::uint32_t* counts;     // per cell; pass 2: running cursor, zeroed before
  const Index* binStart;     // pass 2 only
  Index* binItems;           // pass 2 only
  bool fill;
  PFLOW_HOSTDEVICE void operator()(Index t) const {
    int lo[3], hi[3];
    triangleCellRange(grid, verts + 3 * t, margin, lo, hi);
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          const std::uint32_t c = grid.index(x, y, z);
          const std::uint32_t at = atomicAddU32(&counts[c], 1u);
          if (fill) binItems[binStart[c] + at] = t;
        }
  }
};

// Sorts each cell's triangle list so the result does not depend on thread timing.
struct SortBins {
  const Index* binStart;
  Index* binItems;
  PFLOW_HOSTDEVICE void operator()(Index c) const {
    for (Index a = binStart[c] + 1; a < binStart[c + 1]; ++a) {
      const Index v = binItems[a];
      Index b = a;
      while (b > binStart[c] && binItems[b - 1] > v) {
        binItems[b] = binItems[b - 1];
        --b;
      }
      binItems[b] = v;
    }
  }
};

// Walls near particle i at rebuild time: planes within r_i + skin (a bit mask) and triangles within
// r_i + skin (from its cell's bin). Wall-history slots of walls no longer near are cleared.
// R: the precision of the radii.
template <class R>
struct WallCandidates {
  static constexpr bool kVariableCost = true;  // work per particle varies (CpuExecutor::forEach)
  CellGrid grid;
  const PlaneParams* planes;
  int numPlanes;
  const Index* binStart;  // null when there are no triangles
  const Index* binItems;
  const Vec3d* verts;
  const Vec3d* pos;
  const R* radius;
  double skin;
  // Triangle candidates in rows of exact length, as the particle candidates: the counting pass (countOnly) writes
  // each particle's count to start[i]; the host scans them in place (start[n] the end of the last row); the
  // filling pass writes row i to cand[start[i] .. start[i + 1]). Both null when there are no triangles.
  Index* cand;
  std::uint32_t* start;
  std::uint32_t* planeMask;  // [i]
  std::uint64_t* wallKey;
  int wallSlots;
  SlotLayout slotLayout;
  Conditions* cond;
  bool countOnly = false;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const Vec3d x = pos[i];
    const double cut = double(radius[i]) + skin;
    std::uint32_t count = 0;
    const std::uint32_t first = countOnly || !start ? 0 : start[i];
    const std::uint32_t capacity = countOnly || !start ? 0 : start[i + 1] - first;
    if (binStart) {
      const std::uint32_t c = grid.cellOf(x);
      for (Index k = binStart[c]; k < binStart[c + 1]; ++k) {
        const Index t = binItems[k];
        const auto cp = geometry::closestPointOnTriangle(x, verts[3 * t], verts[3 * t + 1], verts[3 * t + 2]);
        if (norm2(x - cp.point) >= cut * cut) continue;
        if (count < capacity) cand[first + count] = t;
        ++count;
      }
    }
    if (countOnly) {
      start[i] = count;
      return;
    }
    if (count != capacity) {  // the same walk over the same positions: never, but never written past a row either
      atomicOrU32(&cond->flags, kNeighborMismatch);
      return;
    }
    std::uint32_t mask = 0;
    for (int p = 0; p < numPlanes; ++p)
      if (dot(x - planes[p].point, planes[p].normal) < cut) mask |= 1u << p;
    planeMask[i] = mask;
    const SlotRow<std::uint64_t> key = slotLayout.at(wallKey, i);
    for (int k = 0; k < wallSlots; ++k) {
      if (key[k] == kNoGid) continue;
      bool near = false;
      if (key[k] >> 63) {
        near = (mask >> (key[k] & 31u)) & 1u;
      } else {
        for (std::uint32_t e = 0; e < count && !near; ++e) near = (key[k] & 0xffffffffu) == cand[first + e];
      }
      if (!near) key[k] = kNoGid;
    }
  }
};

}  // namespace kernels
}  // namespace pflow::compute
