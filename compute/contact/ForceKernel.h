// Contact forces on one particle per thread, from its full candidate list (each pair is evaluated by
// both partners, so every thread writes only its own particle: no atomics, same result on CPU and GPU).
//
// Tangential history is double-buffered: a thread reads its particle's slots from the current
// buffers and writes the next ones, so a pass that overflows its slots can be redone exactly after
// the slots are grown. Slots are keyed by the partner's gid (particles) or a wall key (walls).
#pragma once
#include <cstdint>

#include "compute/contact/ContactModels.h"
#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/geometry/MeshKernels.h"

namespace pflow::compute {

struct PlaneParams {
  Vec3d point;
  Vec3d normal;  // unit, towards the particles
  std::int32_t material;
};

// Wall keys: planes have the top bit set; triangles carry their mesh in the upper word.
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint64_t planeKey(Index p) { return (std::uint64_t(1) << 63) | p; }
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint64_t triangleKey(std::int32_t mesh, Index t) {
  return (std::uint64_t(std::uint32_t(mesh)) << 32) | t;
}
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool sameMesh(std::uint64_t a, std::uint64_t b) {
  return !(a >> 63) && !(b >> 63) && (a >> 32) == (b >> 32);
}

inline constexpr int kMaxWallContacts = 16;  // simultaneous wall contacts of one particle

namespace kernels {

struct ForceArgs {
  // particles
  const Vec3d* pos;
  const Vec3d* vel;
  const Vec3d* omega;
  const double* radius;
  const double* mass;
  const std::int32_t* material;
  const Gid* gid;
  Vec3d* force;
  Vec3d* torque;
  // particle-particle candidates and history
  const Index* nbr;
  std::int8_t* nbrSlot;
  const std::uint32_t* nbrCount;
  Index nbrCapacity;
  int slots;
  const Gid* histPartner;  // current
  const Vec3d* histDisp;
  Gid* histPartnerNext;    // written
  Vec3d* histDispNext;
  // walls
  const PlaneParams* planes;
  int numPlanes;
  const Vec3d* triVerts;
  const std::int32_t* triMesh;
  const std::int32_t* triMaterial;
  const MeshMotionParams* meshMotion;
  const Index* wallCand;
  const std::uint32_t* wallCandCount;
  Index wallCandCapacity;
  int wallSlots;
  const std::uint64_t* wallKey;  // current
  const Vec3d* wallDisp;
  std::uint64_t* wallKeyNext;    // written
  Vec3d* wallDispNext;
  // parameters
  const ContactParams* params;  // [matI * numMaterials + matJ]
  int numMaterials;
  double dt;
  double time;  // at which walls' velocities are evaluated
  Conditions* cond;
};

struct WallContact {
  Vec3d n;            // particle -> wall
  Vec3d point;        // closest point on the wall
  Vec3d faceNormal;   // the face's normal (for the co-planarity filter)
  Vec3d wallVel;
  double overlap;
  std::uint64_t key;
  std::int32_t material;
  bool isFace;
};

struct ComputeForces {
  ForceArgs a;

  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const Vec3d xi = a.pos[i], vi = a.vel[i], wi = a.omega[i];
    const double ri = a.radius[i], mi = a.mass[i];
    const double Ii = 0.4 * mi * ri * ri;
    const std::int32_t mati = a.material[i];
    Vec3d f = zero3<double>(), tq = zero3<double>();

    // ---- particle-particle ----
    const std::size_t hrow = std::size_t(i) * a.slots;
    for (int k = 0; k < a.slots; ++k) a.histPartnerNext[hrow + k] = kNoGid;
    const std::size_t nrow = std::size_t(i) * a.nbrCapacity;
    const std::uint32_t count = a.nbrCount[i] < a.nbrCapacity ? a.nbrCount[i] : a.nbrCapacity;
    std::uint32_t contacts = 0;
    bool overflow = false;
    for (std::uint32_t e = 0; e < count; ++e) {
      const Index j = a.nbr[nrow + e];
      const Vec3d d = a.pos[j] - xi;
      const double rj = a.radius[j], rs = ri + rj;
      const double d2 = norm2(d);
      if (d2 >= rs * rs) {
        a.nbrSlot[nrow + e] = -1;
        continue;
      }
      ++contacts;
      const double dist = std::sqrt(d2);
      const Vec3d n = (1.0 / dist) * d;
      const double overlap = rs - dist;
      const Gid gj = a.gid[j];
      int slot = a.nbrSlot[nrow + e];
      Vec3d xiOld = zero3<double>();
      if (slot >= 0 && a.histPartner[hrow + slot] == gj) {
        xiOld = a.histDisp[hrow + slot];
      } else {
        slot = freeSlot(a.histPartner + hrow, a.histPartnerNext + hrow, a.slots);
        if (slot < 0) overflow = true;
      }
      const double mj = a.mass[j];
      const double Ij = 0.4 * mj * rj * rj;
      const double li = ri - 0.5 * overlap, lj = rj - 0.5 * overlap;
      contact::ContactState<double> s;
      s.n = n;
      s.overlap = overlap;
      s.vRel = (vi + cross(wi, li * n)) - (a.vel[j] + cross(a.omega[j], -lj * n));
      s.omegaRel = wi - a.omega[j];
      s.effRadius = ri * rj / rs;
      s.effMass = mi * mj / (mi + mj);
      s.effInertia = Ii * Ij / (Ii + Ij);
      s.leverArm = li;
      const auto out = contact::hertzMindlin(a.params[mati * a.numMaterials + a.material[j]], s, xiOld, a.dt);
      f += out.force;
      tq += out.torque;
      if (slot >= 0) {
        a.histPartnerNext[hrow + slot] = gj;
        a.histDispNext[hrow + slot] = out.history;
      }
      a.nbrSlot[nrow + e] = std::int8_t(slot);
    }
    if (overflow) {
      atomicOrU32(&a.cond->flags, kHistoryOverflow);
      atomicMaxU32(&a.cond->neededHistory, contacts);
    }

    // ---- walls ----
    wallForces(i, xi, vi, wi, ri, mi, Ii, mati, f, tq);

    a.force[i] = f;
    a.torque[i] = tq;
  }

  // A slot empty in the current buffer and not yet taken in the next one, or -1.
  PFLOW_HOSTDEVICE static int freeSlot(const Gid* cur, const Gid* next, int slots) {
    for (int k = 0; k < slots; ++k)
      if (cur[k] == kNoGid && next[k] == kNoGid) return k;
    return -1;
  }

  PFLOW_HOSTDEVICE void wallForces(Index i, Vec3d xi, Vec3d vi, Vec3d wi, double ri, double mi, double Ii,
                                   std::int32_t mati, Vec3d& f, Vec3d& tq) const {
    WallContact wc[kMaxWallContacts];
    int nwc = 0;
    bool tooMany = false;
    for (int p = 0; p < a.numPlanes; ++p) {
      const PlaneParams& pl = a.planes[p];
      const double sd = dot(xi - pl.point, pl.normal);
      if (sd >= ri) continue;
      if (nwc == kMaxWallContacts) { tooMany = true; break; }
      wc[nwc++] = {-pl.normal, xi - sd * pl.normal, pl.normal, zero3<double>(), ri - sd, planeKey(Index(p)), pl.material, true};
    }
    const std::uint32_t nc = a.wallCandCount[i] < a.wallCandCapacity ? a.wallCandCount[i] : a.wallCandCapacity;
    for (std::uint32_t e = 0; e < nc; ++e) {
      const Index t = a.wallCand[std::size_t(i) * a.wallCandCapacity + e];
      const Vec3d* v = a.triVerts + 3 * t;
      const auto cp = geometry::closestPointOnTriangle(xi, v[0], v[1], v[2]);
      const Vec3d dv = cp.point - xi;
      const double d2 = norm2(dv);
      if (d2 >= ri * ri) continue;
      if (nwc == kMaxWallContacts) { tooMany = true; break; }
      const Vec3d fn = geometry::triangleNormal(v[0], v[1], v[2]);
      const double d = std::sqrt(d2);
      const Vec3d n = d > 0 ? (1.0 / d) * dv : -fn;
      const std::int32_t mesh = a.triMesh[t];
      wc[nwc++] = {n, cp.point, fn, a.meshMotion[mesh].velocityAt(cp.point, a.time), ri - d, triangleKey(mesh, t),
                   a.triMaterial[t], cp.feature == geometry::Feature::kFace};
    }
    if (tooMany) atomicOrU32(&a.cond->flags, kTooManyWallContacts);

    // Keep only genuine contacts: deepest first; drop a contact at the same point as a kept one
    // (an edge or vertex shared by two triangles), and an edge or vertex contact lying in the plane
    // of a kept face contact (the neighbour triangle's rim seen through a flat surface).
    sortByOverlap(wc, nwc);
    bool keep[kMaxWallContacts];
    const double tol = 1e-9 * ri;
    for (int k = 0; k < nwc; ++k) {
      keep[k] = true;
      for (int m = 0; m < k && keep[k]; ++m) {
        if (!keep[m]) continue;
        if (norm2(wc[k].point - wc[m].point) <= tol * tol) keep[k] = false;
        else if (!wc[k].isFace && wc[m].isFace && std::fabs(dot(wc[m].faceNormal, wc[k].point - wc[m].point)) <= tol)
          keep[k] = false;
      }
    }

    // History slots: same key continues; a new triangle of the same mesh inherits the slot of a
    // triangle of that mesh the particle has just left (rolling across a shared edge keeps its
    // tangential spring); otherwise a free slot.
    const std::size_t wrow = std::size_t(i) * a.wallSlots;
    const std::uint64_t* oldKey = a.wallKey + wrow;
    std::uint64_t* newKey = a.wallKeyNext + wrow;
    for (int k = 0; k < a.wallSlots; ++k) newKey[k] = kNoGid;
    int slotOf[kMaxWallContacts];
    for (int k = 0; k < nwc; ++k) {
      slotOf[k] = -1;
      if (!keep[k]) continue;
      for (int s = 0; s < a.wallSlots; ++s)
        if (oldKey[s] == wc[k].key) { slotOf[k] = s; newKey[s] = wc[k].key; }
    }
    bool overflow = false;
    int kept = 0;
    for (int k = 0; k < nwc; ++k) {
      if (!keep[k]) continue;
      ++kept;
      if (slotOf[k] >= 0) continue;
      for (int s = 0; s < a.wallSlots && slotOf[k] < 0; ++s) {
        if (newKey[s] != kNoGid || oldKey[s] == kNoGid || !sameMesh(oldKey[s], wc[k].key)) continue;
        bool stillTouching = false;
        for (int m = 0; m < nwc; ++m) stillTouching |= keep[m] && wc[m].key == oldKey[s];
        if (!stillTouching) slotOf[k] = s;
      }
      for (int s = 0; s < a.wallSlots && slotOf[k] < 0; ++s)
        if (newKey[s] == kNoGid && oldKey[s] == kNoGid) slotOf[k] = s;
      if (slotOf[k] < 0) overflow = true;
      else newKey[slotOf[k]] = wc[k].key;
    }
    if (overflow) {
      atomicOrU32(&a.cond->flags, kWallHistoryOverflow);
      atomicMaxU32(&a.cond->neededWallHistory, std::uint32_t(kept));
    }

    for (int k = 0; k < nwc; ++k) {
      if (!keep[k]) continue;
      const WallContact& c = wc[k];
      const int s = slotOf[k];
      const double li = ri - 0.5 * c.overlap;
      contact::ContactState<double> st;
      st.n = c.n;
      st.overlap = c.overlap;
      st.vRel = (vi + cross(wi, li * c.n)) - c.wallVel;
      st.omegaRel = wi;
      st.effRadius = ri;
      st.effMass = mi;
      st.effInertia = Ii;
      st.leverArm = li;
      const Vec3d xiOld = s >= 0 && oldKey[s] != kNoGid ? a.wallDisp[wrow + s] : zero3<double>();
      const auto out = contact::hertzMindlin(a.params[mati * a.numMaterials + c.material], st, xiOld, a.dt);
      f += out.force;
      tq += out.torque;
      if (s >= 0) a.wallDispNext[wrow + s] = out.history;
    }
  }

  PFLOW_HOSTDEVICE static void sortByOverlap(WallContact* wc, int n) {
    for (int k = 1; k < n; ++k) {
      WallContact v = wc[k];
      int m = k;
      while (m > 0 && wc[m - 1].overlap < v.overlap) {
        wc[m] = wc[m - 1];
        --m;
      }
      wc[m] = v;
    }
  }
};

}  // namespace kernels
}  // namespace pflow::compute
