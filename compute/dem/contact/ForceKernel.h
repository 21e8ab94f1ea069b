// Contact forces on one particle per thread, from its full candidate list (each pair is evaluated by
// both partners, so every thread writes only its own particle: no atomics, same result on CPU and GPU).
//
// Tangential history lives in per-particle slots keyed by the partner's gid (particles) or a wall
// key (walls), updated in place: a slot is claimed when a contact starts and cleared when it ends.
// When a new contact finds no free slot, the pass still computes its force exactly (a new contact
// starts from zero displacement) and raises a flag; the host grows the slots and runs a store-only
// pass that records just the displacements that could not be stored, so growth changes no result.
#pragma once
#include <type_traits>
#include <cstdint>

#include "compute/dem/contact/ContactModels.h"
#include "compute/dem/contact/HistoryPool.h"
#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/dem/geometry/MeshKernels.h"
#include "compute/neighbor/NeighborKernels.h"

namespace pflow::compute {

inline constexpr int kMaxWallContacts = 16;  // simultaneous wall contacts of one particle

namespace kernels {

// An overlap beyond simulation.max_overlap (ForceArgs::maxOverlap): the run stops, naming the lowest such particle.
PFLOW_HOSTDEVICE inline void flagDeepOverlap(Conditions* cond, Index i) {
  atomicOrU32(&cond->flags, kExcessiveOverlap);
  atomicMinU32(&cond->deepParticle, i);
}

// v added to *p component by component, atomically (ComputeForces' kHalf).
template <class R> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicAddVec(Vec3<R>* p, Vec3<R> v) {
  atomicAddReal(&p->x, v.x), atomicAddReal(&p->y, v.y), atomicAddReal(&p->z, v.z);
}

// A centre behind a plane, or carried through a triangle's face within the step:
// the particle passed through a wall. The run stops, naming the lowest such particle.
PFLOW_HOSTDEVICE inline void flagTunnelled(Conditions* cond, Index i) {
  atomicOrU32(&cond->flags, kTunnelled);
  atomicMinU32(&cond->tunnelParticle, i);
}

// R: the run's precision. Positions are double at both precisions and the contact geometry (separation,
// distance, overlap, closest point on a wall) is computed in double from them (the float pairs once on the GPU: the
// separation and rs^2 - d^2 in double, the rest in float, pairState's kFloatOverlap); the physics (relative
// velocities, forces, torques, history) runs in R.
template <class R>
struct ForceArgs {
  // particles
  const Vec3d* pos;
  const Vec3<R>* vel;
  const Vec3<R>* omega;
  const R* radius;
  const R* mass;
  const std::int32_t* material;
  const Gid* gid;
  Vec3<R>* force;
  Vec3<R>* torque;
  // particle-particle candidates and history
  const Index* nbr;
  std::int8_t* nbrSlot;
  RowSlices nbrLayout;
  int slots;
  PartnerId* histPartner;
  Vec3<R>* histDisp;
  SlotLayout histLayout;
  HistoryPool<R> pool;   // the histories beyond the inline slots (HistoryPool.h); pool.key null: none
  std::int32_t* pooled;  // [i]: i's contacts held in the pool
  int maxContacts;       // simulation.max_contacts: a particle with more is an error, pool or not
  // walls
  const PlaneParams* planes;
  const std::uint32_t* planeMask;  // per particle: planes within r + skin at the last rebuild
  const Vec3d* triVerts;
  const std::int32_t* triMesh;
  const std::int32_t* triMaterial;
  const std::int32_t* triSurface;    // surface number of each triangle
  const std::int32_t* planeSurface;  // surface number of each plane
  double* surfaceLoads;              // null, or 6 per surface (force on the wall [N], torque on it about the origin
                                     // [N m]) summed over this pass's wall contacts (Engine::recordWallLoads)
  const MeshMotionParams* meshMotion;
  const Index* wallCand;                // particle i's triangle candidates: [wallCandStart[i], wallCandStart[i + 1])
  const std::uint32_t* wallCandStart;   // null when there are no triangles
  int wallSlots;
  std::uint64_t* wallKey;
  Vec3<R>* wallDisp;
  SlotLayout wallLayout;
  // parameters
  const ContactParams* params;  // [matI * numMaterials + matJ]
  int numMaterials;
  double dt;
  double time;      // at which walls' velocities are evaluated
  double maxOverlap;  // overlap limit relative to the smaller radius (simulation.max_overlap)
  bool storeOnly;   // redo after slot growth: store the displacements that found no slot, nothing else
  bool tangential;  // ModelFlags: false = every friction is 0: normal forces only, no history slots (slots == 0)
  bool rolling;     // ModelFlags: false = every rolling friction is 0: no rolling torque
  Conditions* cond;
  // The float pairs once (kHalf): each particle's force and torque sums as two 16-byte rows, so that a reaction is
  // one vector atomic add (FinishSums copies them to force and torque). The engine gives every float pairs-once pass
  // them; the double one adds into force and torque (no 64-bit vector add); null elsewhere.
  Sum4* sums = nullptr;
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
  std::int32_t surface;  // the wall's surface number (-1: none)
  bool tensile;          // a JKR contact past zero overlap: kept only if it exists already (has its slot)
};

// The contact of particle i with partner j as i sees it, for d = x_j - x_i with |d|^2 = d2 < rs^2 (rs = r_i + r_j),
// shared by the pair kernels. kSpin = false (no friction and no rolling resistance) leaves the spins out:
// v_rel = v_i - v_j (the spin terms are normal to n, so v_n differs from the full model's by round-off only).
// `rollingPair`: this pair has rolling resistance (its effective inertia is needed). `fixedSide`
// (ContactParams::fixedSide, 0 unless a material is fixed): a pair with one fixed particle is damped as the other's
// contact with a wall, its effective mass and inertia the moving particle's own (both fixed: neither moves).
// kFloatOverlap (float only; the GPU's pairs once, ComputeForces' kHalf): the overlap as (rs^2 - d^2) / (rs + d), the
// difference in double (what needs the positions' precision, without the cancellation of rs - d), the rest in float,
// root and quotients approximate on the GPU (FastMath.h): no double root or quotient left. That loop spends most of its
// time evaluating contacts, and its forces phase took 10 % less on an H200 (1.02 -> 0.92 s per 1 000 steps); the
// both-sides loop took about 3 % more (1.08 -> 1.10 in separate calls, at its 80 registers), so it keeps the distance in double
// (docs/performance.md).
template <class R, bool kSpin, bool kFloatOverlap = false>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE contact::ContactState<R> pairState(Vec3d d, double d2, double rs, Vec3<R> vi, Vec3<R> wi,
                                                                    R ri, R mi, R Ii, Vec3<R> vj, Vec3<R> wj, R rj, R mj,
                                                                    bool rollingPair, int fixedSide = 0) {
  contact::ContactState<R> s;
  if constexpr (kFloatOverlap) {
    static_assert(std::is_same_v<R, float>);
    const float dist = sqrtFast(float(d2));
    s.n = divFast(1.0f, dist) * vcast<float>(d);
    s.overlap = divFast(float(rs * rs - d2), float(rs) + dist);
  } else {
    const double dist = std::sqrt(d2);
    s.n = vcast<R>((1.0 / dist) * d);
    s.overlap = R(rs - dist);
  }
  const R overlap = s.overlap;
  const Vec3<R> n = s.n;
  s.effRadius = divFast(ri * rj, ri + rj);
  const R pairMass = divFast(mi * mj, mi + mj);
  s.effMass = fixedSide == 2 ? mi : fixedSide == 1 ? mj : pairMass;
  if constexpr (kSpin) {
    const R li = ri - R(0.5) * overlap, lj = rj - R(0.5) * overlap;
    s.vRel = (vi + cross(wi, li * n)) - (vj + cross(wj, -lj * n));
    s.omegaRel = wi - wj;
    s.leverArm = li;
    if (rollingPair) {
      const R Ij = R(0.4) * mj * rj * rj;
      const R pairInertia = Ii * divFast(Ij, Ii + Ij);  // not Ii*Ij/(Ii+Ij): that product underflows in float below ~10 um
      s.effInertia = fixedSide == 2 ? Ii : fixedSide == 1 ? Ij : pairInertia;
    } else {
      s.effInertia = R(0);  // unused without rolling resistance
    }
  } else {
    (void)wi, (void)wj, (void)Ii, (void)rollingPair;
    s.vRel = vi - vj;
    s.omegaRel = zero3<R>();
    s.effInertia = R(0);
    s.leverArm = ri;
  }
  return s;
}

// Contact forces of particle i from its candidate row. Every pair is evaluated by both partners
// (operator(), the GPU's way: each thread writes only its own particle, no atomics), or, on the CPU, by
// its owner only (kOnce, from ComputePairsOnce), which then also adds the reaction to the partner.
// kCohesion: the loop with adhesion (ModelFlags::cohesion), a kernel of its own so that its registers do not
// weigh on scenes without it. kFixed: a scene with fixed materials (ContactParams::fixedSide read per pair, pairState);
// a kernel of its own too (the select cost the float forces phase 6 % on an H100 when every scene carried it).
// kTwoPhase (executors whose lanes run in lockstep: the GPU's; EngineImpl::m_twoPhase): each piece of 32
// candidates is first only tested, a bit set for each that touches or holds a slot, then the marked ones are
// evaluated, in the row's order. Evaluating each candidate where it is tested kept a warp in the contact's
// arithmetic for every candidate any lane touched (14.5 of 32 lanes active, ncu, H200): now a warp runs as many
// evaluations as its busiest lane has contacts. The unmarked candidates are those the one-phase loop passes over
// without effect, so the sums, the slots claimed and the pool's entries are the same bit for bit.
// kHalf (with kTwoPhase; the GPU's pairs once, EngineImpl::m_halfPairs, measurements): each pair is evaluated by its
// lower index only, whose row holds only its candidates above it (BuildNeighbors::upperOnly); it adds the reaction to its partner's sums and its own by atomic adds (the sums start at zero:
// ZeroSums); the owner alone keeps the history (PullHistoryHalf). Float atomics add in no fixed order: a run is
// not bit-reproducible this way.
template <class R, bool kCohesion = false, bool kFixed = false, bool kTwoPhase = false, bool kHalf = false>
struct ComputeForces {
  static_assert(!kHalf || kTwoPhase, "the pairs-once loop is the two-phase one");
  static constexpr bool kVariableCost = true;  // work per particle varies (CpuExecutor::forEach)
  // Held to 80 registers a thread in float and 128 in double in the two-phase loop (the GPU's), against the compiler's
  // own 88-92 and 130-136. In float 80 keeps 24 warps an SM for 56 B of spill loads; 96 (20 warps, no spills) made
  // the forces phase 10 % longer, 72 and 88 8-10 %. In double 112 and 120 were 7 % and 2 % slower than 128 (H200).
  // The one-phase loop (the GPU's only in measurements): 80 in float, 96 in double (the adhesion loop 128).
  // docs/performance.md ("Forces"); CudaExecutor::forEach.
  static constexpr int kMaxRegisters = !std::is_same_v<R, double> ? 80 : kTwoPhase || kCohesion ? 128 : 96;
  using V = Vec3<R>;
  ForceArgs<R> a;

  PFLOW_HOSTDEVICE void operator()(Index i) const { dispatch<false>(i, nullptr); }

  // The least model picks the loop: without friction (ModelFlags::tangential) no slot is read or written;
  // without rolling resistance either, spins do not enter (pairState's kSpin). Adhesion (ModelFlags::cohesion)
  // has a loop of its own, so that scenes without it pay nothing for it; it implies the slots.
  template <bool kOnce>
  PFLOW_HOSTDEVICE void dispatch(Index i, const std::uint32_t* owned) const {
    if constexpr (kCohesion) {
      if (a.rolling) row<true, true, true, kOnce>(i, owned);
      else row<true, false, true, kOnce>(i, owned);
    } else if (!a.tangential) {
      if (a.rolling) row<false, true, false, kOnce>(i, owned);
      else row<false, false, false, kOnce>(i, owned);
    } else if (a.rolling) {
      row<true, true, false, kOnce>(i, owned);
    } else {
      row<true, false, false, kOnce>(i, owned);
    }
  }

  // kOnce: only the first owned[i] candidates, the pairs i owns (OwnedFirst); -F and the partner's torque
  // are added to j's sums, and i's are added to what its partners already put there.
  template <bool kTangential, bool kRolling, bool kAdhesion, bool kOnce>
  PFLOW_HOSTDEVICE void row(Index i, const std::uint32_t* owned) const {
    constexpr bool kSpin = kTangential || kRolling;
    constexpr bool kReact = kOnce || kHalf;  // i adds the reaction to its partner
    // Local restrict copies: the int8 slot stores could otherwise alias every pointer in `a` and
    // force the compiler to reload them after each store.
    const Vec3d* __restrict__ pos = a.pos;
    const V* __restrict__ vel = a.vel;
    const V* __restrict__ omega = a.omega;
    const R* __restrict__ radius = a.radius;
    const R* __restrict__ mass = a.mass;
    const std::int32_t* __restrict__ material = a.material;
    const Gid* __restrict__ gid = a.gid;
    V* __restrict__ force = a.force;
    V* __restrict__ torque = a.torque;
    const std::size_t row = a.nbrLayout.base(i);
    const Index* __restrict__ nbr = a.nbr + row;
    std::int8_t* __restrict__ nbrSlot = a.nbrSlot + row;
    const std::size_t col = a.nbrLayout.stride();
    const HistoryPool<R>& pool = a.pool;  // read from the launch's parameters where used, not held in registers
    RowHistory h = history(i);
    const ContactParams* __restrict__ params = a.params + std::size_t(material[i]) * a.numMaterials;
    const R dt = R(a.dt);
    const bool storeOnly = a.storeOnly;

    const Vec3d xi = pos[i];
    const V vi = vel[i], wi = kSpin ? omega[i] : zero3<R>();
    const R ri = radius[i], mi = mass[i];
    const R Ii = R(0.4) * mi * ri * ri;
    V f = zero3<R>(), tq = zero3<R>();

    const std::uint32_t count = kOnce ? owned[i] : a.nbrLayout.count(i);
    // One candidate, as the one-phase loop sees it: tested, then (touching, or ending a contact that holds a slot)
    // evaluated, its history kept. `return` passes on to the next.
    const auto candidate = [&](std::uint32_t e) PFLOW_FORCEINLINE_LAMBDA {
      const Index j = nbr[e * col];
      const Vec3d d = pos[j] - xi;
      const R rj = radius[j];
      const double rs = double(ri) + double(rj);
      const double d2 = norm2(d);
      int slot = -1;
      std::int32_t entry = -1;  // the pool's entry when slot == kPoolSlot
      V xiOld = zero3<R>();
      if (!admit<kTangential, kAdhesion>(h, nbrSlot + e * col, j, d2, rs, ri, rj, params, material, gid, slot, entry, xiOld))
        return;
      const R mj = mass[j];
      const ContactParams& pp = params[material[j]];
      const contact::ContactState<R> s = pairState<R, kSpin, kHalf && std::is_same_v<R, float>>(d, d2, rs, vi, wi, ri, mi, Ii, vel[j],
                                                             kSpin ? omega[j] : zero3<R>(), rj, mj,
                                                             kRolling && pp.rollingFriction > 0, kFixed ? pp.fixedSide : 0);
      if (s.overlap > R(a.maxOverlap) * (ri < rj ? ri : rj)) {
        flagDeepOverlap(a.cond, i);
        if (kReact) flagDeepOverlap(a.cond, j);  // as j's own evaluation would
      }
      const auto out = contact::hertzMindlin<kTangential, kRolling, kAdhesion>(pp, s, xiOld, dt);
      if constexpr (kTangential) {
        if (slot == kPoolSlot) {
          if (entry >= 0) pool.disp[entry] = out.history;
        } else if (slot >= 0) {
          h.disp[slot] = out.history;
        }
        nbrSlot[e * col] = std::int8_t(slot);
      }
      f += out.force;
      if constexpr (kSpin) tq += out.torque;
      if constexpr (kHalf) {
        if (!storeOnly) {
          const V tj = kSpin ? contact::partnerTorque(out, s.n, rj - R(0.5) * s.overlap) : zero3<R>();
          if constexpr (std::is_same_v<R, float>) {
            atomicAddSum4(&a.sums[2 * std::size_t(j)], -out.force.x, -out.force.y, -out.force.z);
            if constexpr (kSpin) atomicAddSum4(&a.sums[2 * std::size_t(j) + 1], tj.x, tj.y, tj.z);
          } else {
            atomicAddVec(&force[j], -out.force);
            if constexpr (kSpin) atomicAddVec(&torque[j], tj);
          }
        }
      } else if constexpr (kOnce) {
        if (!storeOnly) {
          force[j] -= out.force;
          if constexpr (kSpin) torque[j] += contact::partnerTorque(out, s.n, rj - R(0.5) * s.overlap);
        }
      }
    };
    if constexpr (kTwoPhase && !kOnce) {
      for (std::uint32_t base = 0; base < count; base += 32) {
        const std::uint32_t end = count - base > 32 ? base + 32 : count;
        std::uint32_t marked = 0;
        // Unrolled twice, not the compiler's four times: fewer registers held across the test, 40 B of spill loads
        // instead of 56 at the float kernel's 80 registers, the float forces phase 4 % shorter (1.18 against 1.23 s
        // per 1 000 steps, H200 settled bed); not unrolled the same in float, 3 % slower in double.
#if defined(__CUDA_ARCH__)
#pragma unroll 2
#endif
        for (std::uint32_t e = base; e < end; ++e) {
          const Index j = nbr[e * col];
          const double rs = double(ri) + double(radius[j]);
          // A hair wider than the candidate's own test, which decides: its sums may contract otherwise.
          bool visit = norm2(pos[j] - xi) < rs * rs * (1 + 1e-9);
          if constexpr (kTangential) visit |= nbrSlot[e * col] >= 0;
          marked |= std::uint32_t(visit) << (e - base);
        }
        while (marked) {
          const int b = lowestBit(marked);
          marked &= marked - 1;
          candidate(base + std::uint32_t(b));
        }
      }
    } else {
      for (std::uint32_t e = 0; e < count; ++e) candidate(e);
    }
    endRow<kTangential, kOnce>(i, h, owned);
    if (storeOnly) return;
    if constexpr (kHalf) {  // the sums start at zero (ZeroSums): without spins i's torque stays so
      if constexpr (std::is_same_v<R, float>) {
        atomicAddSum4(&a.sums[2 * std::size_t(i)], f.x, f.y, f.z);
        if constexpr (kSpin) atomicAddSum4(&a.sums[2 * std::size_t(i) + 1], tq.x, tq.y, tq.z);
      } else {
        atomicAddVec(&force[i], f);
        if constexpr (kSpin) atomicAddVec(&torque[i], tq);
      }
    } else if constexpr (kOnce) {
      force[i] += f;
      torque[i] += tq;
    } else {
      force[i] = f;
      torque[i] = tq;
    }
  }

  // A row's history bookkeeping: i's slots, its key in the pool, and what its candidates found.
  struct RowHistory {
    SlotRow<PartnerId> partner;
    SlotRow<V> disp;
    PartnerId gi;            // i's gid where there is a pool
    int pooledHere;          // i's contacts held in the pool
    std::uint32_t contacts;  // touching candidates seen (with slots)
    bool overflow;           // a touching candidate found no slot
  };
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE RowHistory history(Index i) const {
    return RowHistory{a.histLayout.at(a.histPartner, i), a.histLayout.at(a.histDisp, i),
                      a.pool.key ? PartnerId(a.gid[i]) : kNoPartner, a.pool.key ? a.pooled[i] : 0, 0u, false};
  }

  // A candidate j of i at |d|^2 = d2 (rs = r_i + r_j) as the one-phase loop tests it, its history kept: false when
  // the pair is passed over (apart, its history forgotten if it had one; or, redoing after slot growth, stored
  // already), else true with the slot that holds it (kPoolSlot and the pool's `entry`; -1: none free, the overflow
  // noted) and its stored displacement `xiOld` (zero for a new contact). `slotByte`: the candidate's slot byte.
  // Shared by the pair loops here and the CPU's batched pairs once (ContactBatch.h).
  template <bool kTangential, bool kAdhesion>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool admit(RowHistory& h, std::int8_t* slotByte, Index j, double d2, double rs, R ri,
                                                R rj, const ContactParams* __restrict__ params,
                                                const std::int32_t* __restrict__ material, const Gid* __restrict__ gid,
                                                int& slot, std::int32_t& entry, V& xiOld) const {
    if constexpr (kTangential) {
      const HistoryPool<R>& pool = a.pool;
      // Invariant: the slot byte is >= 0 exactly when slot nbrSlot[e] holds j's history, or the pool does (kPoolSlot)
      // (set at rebuild, on claiming, cleared here when the contact ends), so the hot path never reads gid[j].
      slot = *slotByte;
      // A JKR contact holds past zero overlap, to its break point; only one that exists (has its slot) does.
      if (d2 >= rs * rs && !(kAdhesion && slot >= 0 && holds(params[material[j]], d2, rs, ri, rj))) {
        if (slot == kPoolSlot) {  // the contact has ended: forget its history
          entry = pool.find(HistoryPool<R>::keyOf(h.gi, PartnerId(gid[j])));
          if (entry >= 0) pool.key[entry] = HistoryPool<R>::kErased;
          --h.pooledHere;
        } else if (slot >= 0) {
          h.partner[slot] = kNoPartner;
        }
        if (slot >= 0) *slotByte = -1;
        return false;
      }
      ++h.contacts;
      if (slot >= 0) {
        if (a.storeOnly) return false;  // stored by the first pass
        if (slot == kPoolSlot) {
          entry = pool.find(HistoryPool<R>::keyOf(h.gi, PartnerId(gid[j])));
          if (entry >= 0) xiOld = pool.disp[entry];
        } else {
          xiOld = h.disp[slot];
        }
      } else {
        slot = claimSlot(h.partner, a.slots, gid[j]);
        if (slot < 0 && pool.key) {  // inline slots full: the pool
          entry = pool.insert(HistoryPool<R>::keyOf(h.gi, PartnerId(gid[j])));
          if (entry >= 0) slot = kPoolSlot, ++h.pooledHere;
        }
        h.overflow |= slot < 0;
        if (a.storeOnly && slot < 0) return false;
      }
      return true;
    } else {
      (void)h, (void)slotByte, (void)j, (void)ri, (void)rj, (void)params, (void)material, (void)gid, (void)slot, (void)entry,
          (void)xiOld;
      return d2 < rs * rs;
    }
  }

  // The end of i's row: the slots' overflow and the pool's count.
  template <bool kTangential, bool kOnce>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void endRow(Index i, RowHistory& h, const std::uint32_t* owned) const {
    if (h.overflow) {
      // Slots are sized, and held to simulation.max_contacts, by all of i's contacts in both ways of
      // evaluating: the limit means the same, and a pair changing owner finds a free slot.
      if constexpr (kOnce) h.contacts += touchingNotOwned(i, owned);  // kHalf: the slots hold the owned ones only
      atomicOrU32(&a.cond->flags, kHistoryOverflow);
      atomicMaxU32(&a.cond->neededHistory, h.contacts);
    }
    if constexpr (kTangential) {
      if (a.pool.key) {
        a.pooled[i] = h.pooledHere;
        // The pool takes what the inline slots do not: simulation.max_contacts still holds.
        if (h.contacts > std::uint32_t(a.maxContacts)) atomicMaxU32(&a.cond->neededHistory, h.contacts);
      }
    }
  }

  // Does an existing JKR contact at centre distance sqrt(d2) > rs (negative overlap) still hold?
  PFLOW_HOSTDEVICE static bool holds(const ContactParams& p, double d2, double rs, R ri, R rj) {
    if (p.cohesion != contact::cohesion::kJkr) return false;
    const R effRadius = ri * rj / (ri + rj);
    return R(rs - std::sqrt(d2)) > contact::cohesion::jkrBreakOverlap(R(p.jkrBreak), effRadius);
  }

  // Claims an empty slot for partner g, or returns -1 when all are taken.
  PFLOW_HOSTDEVICE static int claimSlot(SlotRow<PartnerId> partner, int slots, Gid g) {
    for (int k = 0; k < slots; ++k)
      if (partner[k] == kNoPartner) {
        partner[k] = PartnerId(g);
        return k;
      }
    return -1;
  }

  // How many of the candidates particle i does not own touch it (counted only when its slots overflow).
  PFLOW_HOSTDEVICE std::uint32_t touchingNotOwned(Index i, const std::uint32_t* owned) const {
    const std::uint32_t count = a.nbrLayout.count(i);
    std::uint32_t n = 0;
    for (std::uint32_t e = owned[i]; e < count; ++e) {
      const Index j = a.nbr[a.nbrLayout.at(i, e)];
      const double rs = double(a.radius[i]) + double(a.radius[j]);
      n += norm2(a.pos[j] - a.pos[i]) < rs * rs;
    }
    return n;
  }
};

// Wall contact forces on one particle per thread, added to the pair forces that ComputeForces stored
// (the same summation order as one pass). A separate kernel because its per-thread contact list
// (kMaxWallContacts entries) needs a stack frame and registers that would slow the pair loop for
// every particle, while only the particles near a wall have work here; the others return at once.
template <class R, bool kCohesion = false>
struct ComputeWallForces {
  static constexpr bool kVariableCost = true;  // work per particle varies (CpuExecutor::forEach)
  using V = Vec3<R>;
  ForceArgs<R> a;

  PFLOW_HOSTDEVICE void operator()(Index i) const {
    if (a.planeMask[i] == 0 && (!a.wallCandStart || a.wallCandStart[i + 1] == a.wallCandStart[i])) return;  // far from every wall (slots cleared at rebuild)
    const ContactParams* params = a.params + std::size_t(a.material[i]) * a.numMaterials;
    const R ri = a.radius[i], mi = a.mass[i];
    V f = zero3<R>(), tq = zero3<R>();
    if (!a.storeOnly) {
      f = a.force[i];
      tq = a.torque[i];
    }
    wallForces(i, a.pos[i], a.vel[i], a.omega[i], ri, mi, R(0.4) * mi * ri * ri, params, f, tq);
    if (!a.storeOnly) {
      a.force[i] = f;
      a.torque[i] = tq;
    }
  }

  // Triangles are stored as a soup; neighbours share vertices bit for bit (same source vertex, same
  // motion applied), so exact comparison finds them.
  PFLOW_HOSTDEVICE bool sharesVertex(Index t, Index u) const {
    const Vec3d* a3 = a.triVerts + 3 * t;
    const Vec3d* b3 = a.triVerts + 3 * u;
    for (int p = 0; p < 3; ++p)
      for (int q = 0; q < 3; ++q)
        if (a3[p].x == b3[q].x && a3[p].y == b3[q].y && a3[p].z == b3[q].z) return true;
    return false;
  }

  // Did the centre pass through the face of triangle v during this step? Its path relative to the wall,
  // from x - (v - v_wall) dt to x, crosses the triangle's plane at a point inside the triangle. A contact
  // force keeps a centre a radius away from the face, so a crossing is never legitimate (from either side).
  PFLOW_HOSTDEVICE bool crossedFace(Vec3d x, V vi, const Vec3d* v, Vec3d closest, const MeshMotionParams& motion) const {
    const Vec3d fn = geometry::triangleNormal(v[0], v[1], v[2]);
    const Vec3d step = a.dt * (vcast<double>(vi) - motion.velocityAt(closest, a.time));
    const double now = dot(x - v[0], fn), before = now - dot(step, fn);
    if ((before > 0) == (now > 0) || before == now) return false;
    const Vec3d p = x - (now / (now - before)) * step;  // where the path meets the plane
    const auto cp = geometry::closestPointOnTriangle(p, v[0], v[1], v[2]);
    const double tol = 1e-9 * (norm(v[1] - v[0]) + norm(v[2] - v[0]));
    return cp.feature == geometry::Feature::kFace && norm2(p - cp.point) <= tol * tol;
  }

  PFLOW_HOSTDEVICE void wallForces(Index i, Vec3d xi, V vi, V wi, R ri, R mi, R Ii, const ContactParams* params,
                                   V& f, V& tq) const {
    WallContact wc[kMaxWallContacts];
    int nwc = 0;
    bool tooMany = false;
    for (std::uint32_t mask = a.planeMask[i]; mask; mask &= mask - 1) {
      const int p = lowestBit(mask);
      const PlaneParams& pl = a.planes[p];
      const double sd = dot(xi - pl.point, pl.normal);
      if (sd >= double(ri) + reach(params[pl.material], ri)) continue;
      if (sd < 0) {  // the centre is behind the plane: it went through (the mask keeps planes behind)
        flagTunnelled(a.cond, i);
        continue;
      }
      if (nwc == kMaxWallContacts) { tooMany = true; break; }
      if (double(ri) - sd > a.maxOverlap * double(ri)) flagDeepOverlap(a.cond, i);
      wc[nwc++] = {-pl.normal, xi - sd * pl.normal, pl.normal, zero3<double>(), double(ri) - sd, planeKey(Index(p)), pl.material, true,
                   a.planeSurface ? a.planeSurface[p] : -1, sd >= double(ri)};
    }
    const std::uint32_t firstCand = a.wallCandStart ? a.wallCandStart[i] : 0;
    const std::uint32_t nc = a.wallCandStart ? a.wallCandStart[i + 1] - firstCand : 0;
    for (std::uint32_t e = 0; e < nc; ++e) {
      const Index t = a.wallCand[firstCand + e];
      const Vec3d* v = a.triVerts + 3 * t;
      const auto cp = geometry::closestPointOnTriangle(xi, v[0], v[1], v[2]);
      const Vec3d dv = cp.point - xi;
      const double d2 = norm2(dv), rid = double(ri);
      if (a.dt > 0 && crossedFace(xi, vi, v, cp.point, a.meshMotion[a.triMesh[t]])) {
        flagTunnelled(a.cond, i);
        continue;
      }
      const double held = rid + reach(params[a.triMaterial[t]], ri);
      if (d2 >= held * held) continue;
      if (nwc == kMaxWallContacts) { tooMany = true; break; }
      const Vec3d fn = geometry::triangleNormal(v[0], v[1], v[2]);
      const double d = std::sqrt(d2);
      const Vec3d n = d > 0 ? (1.0 / d) * dv : -fn;
      if (rid - d > a.maxOverlap * rid) flagDeepOverlap(a.cond, i);
      const std::int32_t mesh = a.triMesh[t];
      wc[nwc++] = {n, cp.point, fn, a.meshMotion[mesh].velocityAt(cp.point, a.time), rid - d, triangleKey(mesh, t),
                   a.triMaterial[t], cp.feature == geometry::Feature::kFace, a.triSurface ? a.triSurface[t] : -1,
                   d2 >= rid * rid};
    }
    if (tooMany) atomicOrU32(&a.cond->flags, kTooManyWallContacts);
    const SlotRow<std::uint64_t> key = a.wallLayout.at(a.wallKey, i);
    const SlotRow<V> disp = a.wallLayout.at(a.wallDisp, i);
    if (nwc == 0) {  // no wall contact; forget any that just ended
      if (a.planeMask[i] == 0 && nc == 0) return;  // far from every wall: its slots were cleared at rebuild
      for (int k = 0; k < a.wallSlots; ++k)
        if (key[k] != kNoGid) key[k] = kNoGid;
      return;
    }

    // Keep only genuine contacts: deepest first; drop a contact at the same point as a kept one
    // (an edge or vertex shared by two triangles), and an edge or vertex contact lying in the plane
    // of a kept face contact (the neighbour triangle's rim seen through a flat surface).
    sortByOverlap(wc, nwc);
    bool keep[kMaxWallContacts];
    const double tol = 1e-9 * double(ri);
    int kept = 0;
    for (int k = 0; k < nwc; ++k) {
      keep[k] = true;
      for (int m = 0; m < k && keep[k]; ++m) {
        if (!keep[m]) continue;
        if (norm2(wc[k].point - wc[m].point) <= tol * tol) keep[k] = false;
        else if (!wc[k].isFace && wc[m].isFace && std::fabs(dot(wc[m].faceNormal, wc[k].point - wc[m].point)) <= tol)
          keep[k] = false;
      }
      kept += keep[k];
    }

    // Without friction (ModelFlags::tangential off) there are no wall slots: normal (and rolling) forces only.
    if (!a.tangential) {
      for (int k = 0; k < nwc; ++k) {
        if (!keep[k] || wc[k].tensile) continue;  // (adhesion implies the slots: never tensile here)
        const contact::ContactState<R> st = wallState(wc[k], vi, wi, ri, mi, Ii);
        const auto out = a.rolling ? contact::hertzMindlin<false, true>(params[wc[k].material], st, zero3<R>(), R(a.dt))
                                   : contact::hertzMindlin<false, false>(params[wc[k].material], st, zero3<R>(), R(a.dt));
        f += out.force;
        tq += out.torque;
        addLoad(wc[k].surface, xi, out.force, out.torque);
      }
      return;
    }

    // Slots: the same key continues; a new triangle inherits the slot of a neighbouring triangle
    // (same mesh, a shared vertex) the particle has just left, so rolling across a shared edge keeps
    // its tangential spring; otherwise a free slot. Slots of ended contacts are cleared.
    int slotOf[kMaxWallContacts];
    bool claimedNow[kMaxWallContacts];  // took an empty slot in this pass
    bool matched[32];  // wall slots are limited to 32
    for (int s = 0; s < a.wallSlots; ++s) matched[s] = false;
    for (int k = 0; k < nwc; ++k) {
      slotOf[k] = -1;
      claimedNow[k] = false;
      if (!keep[k]) continue;
      for (int s = 0; s < a.wallSlots; ++s)
        if (key[s] == wc[k].key) { slotOf[k] = s; matched[s] = true; }
    }
    bool overflow = false;
    for (int k = 0; k < nwc; ++k) {
      if (!keep[k] || slotOf[k] >= 0) continue;
      for (int s = 0; s < a.wallSlots && slotOf[k] < 0; ++s)
        if (!matched[s] && key[s] != kNoGid && sameMesh(key[s], wc[k].key) &&
            sharesVertex(Index(key[s] & 0xffffffffu), Index(wc[k].key & 0xffffffffu)))
          slotOf[k] = s;  // inherit from the neighbouring triangle just left
      if (wc[k].tensile && slotOf[k] < 0) {  // a JKR contact forms at zero overlap, never beyond it
        keep[k] = false;
        continue;
      }
      for (int s = 0; s < a.wallSlots && slotOf[k] < 0; ++s)
        if (key[s] == kNoGid) { slotOf[k] = s; claimedNow[k] = true; disp[s] = zero3<R>(); }  // fresh
      if (slotOf[k] < 0) overflow = true;
      else { key[slotOf[k]] = wc[k].key; matched[slotOf[k]] = true; }
    }
    for (int s = 0; s < a.wallSlots; ++s)
      if (!matched[s]) key[s] = kNoGid;
    if (overflow) {
      atomicOrU32(&a.cond->flags, kWallHistoryOverflow);
      atomicMaxU32(&a.cond->neededWallHistory, std::uint32_t(kept));
    }

    for (int k = 0; k < nwc; ++k) {
      if (!keep[k]) continue;
      const WallContact& c = wc[k];
      const int s = slotOf[k];
      if (a.storeOnly && !claimedNow[k]) continue;  // the first pass handled it
      const contact::ContactState<R> st = wallState(c, vi, wi, ri, mi, Ii);
      const V xiOld = s >= 0 ? disp[s] : zero3<R>();
      const ContactParams& pc = params[c.material];
      const auto out = a.rolling ? contact::hertzMindlin<true, true, kCohesion>(pc, st, xiOld, R(a.dt))
                                 : contact::hertzMindlin<true, false, kCohesion>(pc, st, xiOld, R(a.dt));
      f += out.force;
      tq += out.torque;
      if (s >= 0) disp[s] = out.history;
      addLoad(c.surface, xi, out.force, out.torque);
    }
  }

  // How far past zero overlap a wall contact of this pair may hold [m]: JKR's break distance (R* = r_i), else 0.
  PFLOW_HOSTDEVICE double reach(const ContactParams& p, R ri) const {
    if (!kCohesion || p.cohesion != contact::cohesion::kJkr) return 0.0;
    return -double(contact::cohesion::jkrBreakOverlap(R(p.jkrBreak), ri));
  }

  // The reaction of one wall contact on its surface: force -F, and torque -(x_i x F + tau) about the origin (the
  // particle's force F and torque tau about its centre x_i: what the contact gives the particle, the wall loses).
  PFLOW_HOSTDEVICE void addLoad(std::int32_t surface, Vec3d xi, V force, V torque) const {
    if (a.surfaceLoads == nullptr || a.storeOnly || surface < 0) return;
    const Vec3d fd = vcast<double>(force);
    const Vec3d t = cross(xi, fd) + vcast<double>(torque);
    double* l = a.surfaceLoads + 6 * std::size_t(surface);
    atomicAddF64(l + 0, -fd.x);
    atomicAddF64(l + 1, -fd.y);
    atomicAddF64(l + 2, -fd.z);
    atomicAddF64(l + 3, -t.x);
    atomicAddF64(l + 4, -t.y);
    atomicAddF64(l + 5, -t.z);
  }

  PFLOW_HOSTDEVICE static contact::ContactState<R> wallState(const WallContact& c, V vi, V wi, R ri, R mi, R Ii) {
    const R overlap = R(c.overlap);
    const R li = ri - R(0.5) * overlap;
    const V n = vcast<R>(c.n);
    contact::ContactState<R> st;
    st.n = n;
    st.overlap = overlap;
    st.vRel = (vi + cross(wi, li * n)) - vcast<R>(c.wallVel);
    st.omegaRel = wi;
    st.effRadius = ri;
    st.effMass = mi;
    st.effInertia = Ii;
    st.leverArm = li;
    return st;
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
