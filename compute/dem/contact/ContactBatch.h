// The CPU's pairs once with the contact law evaluated a batch of contacts at a time, in the core's SIMD lanes (four
// contacts an instruction in double, eight in float, with AVX2): the arithmetic that is most of the CPU's forces
// phase, no longer one contact after another.
//
// A slab's particles are walked as ComputeForces::row walks them (the same test of each owned candidate, the same
// history bookkeeping: ComputeForces::admit), but a contact that is to be evaluated is copied into a batch, its inputs
// as columns (ContactBatch). A full batch is evaluated in one loop over its columns that GCC vectorises
// (evaluateBatch: pairState and hertzMindlin, the physics every executor shares, inlined), then applied in the
// batch's order, one contact at a time (applyBatch): the history stored, the force and torque summed for the owner
// and the reaction added to the partner, each owner's sum added when its row ends. Every operation is the one the
// contact-at-a-time loop does, in the same order: the same bits (BatchedContacts.SameBitsAsOneContactAtATime), given
// that the compiler fuses no multiply-adds of its own (compute/CMakeLists.txt: it fuses lanes and scalars differently).
//
// A batch holds contacts of one material pair (their ContactParams, copied into the evaluation: GCC vectorises the loop
// only when the parameters are loaded outside the lanes' conditions); a contact of another pair evaluates what is
// batched first. Not used with adhesion (its JKR root iterates: the loop does not vectorise) nor for the store-only
// pass after slot growth: ComputePairsOnce evaluates those one contact at a time. Host only.
#pragma once
#include <cstdint>

#include "compute/dem/contact/ForceKernel.h"

namespace pflow::compute::kernels {

template <class R>
struct ContactBatch {
  static constexpr int kSize = 32;  // contacts
  static constexpr int kEnds = 64;  // rows ended since the last application
  using V = Vec3<R>;
  // Inputs, as ComputeForces::row has them for the contact: d = x_j - x_i, |d|^2, r_i + r_j; i's and j's state; the
  // stored tangential displacement.
  double dx[kSize], dy[kSize], dz[kSize], d2[kSize], rs[kSize];
  R vix[kSize], viy[kSize], viz[kSize], wix[kSize], wiy[kSize], wiz[kSize], ri[kSize], mi[kSize];
  R vjx[kSize], vjy[kSize], vjz[kSize], wjx[kSize], wjy[kSize], wjz[kSize], rj[kSize], mj[kSize];
  R hx[kSize], hy[kSize], hz[kSize];
  // Outputs: the force and torque on i, the torque on j, the new displacement, the overlap.
  R fx[kSize], fy[kSize], fz[kSize], tx[kSize], ty[kSize], tz[kSize], ux[kSize], uy[kSize], uz[kSize];
  R ox[kSize], oy[kSize], oz[kSize], overlap[kSize];
  // Where each contact goes: i, j, i's slot (kPoolSlot: the pool's entry) and the candidate's slot byte.
  Index i[kSize], j[kSize];
  int slot[kSize];
  std::int32_t entry[kSize];
  std::int8_t* slotByte[kSize];
  int n = 0;
  std::int64_t pair = -1;  // the contacts' ContactParams index (row-major), -1 while empty
  // Rows that ended: particle endParticle[k]'s sums are added after the first endAt[k] contacts.
  Index endParticle[kEnds];
  int endAt[kEnds];
  int ends = 0;
  // The sums of the row still open when a batch is applied (its contacts span two batches).
  V f = zero3<R>(), tq = zero3<R>();
};

// Evaluates the batch's contacts (columns 0..n-1) with the one pair's parameters `params`. The loop's body is
// ComputeForces::row's evaluation of one contact; GCC vectorises it (-fno-math-errno -fno-trapping-math), and IEEE
// arithmetic in lanes rounds as it does one at a time where no multiply-add is fused implicitly (-ffp-contract=off;
// compute/CMakeLists.txt).
template <class R, bool kTangential, bool kRolling, bool kFixed>
inline void evaluateBatch(ContactBatch<R>& b, const ContactParams& params, R dt) {
  using V = Vec3<R>;
  constexpr bool kSpin = kTangential || kRolling;
  const ContactParams p = params;
  const bool rollingPair = kRolling && p.rollingFriction > 0;
  const int fixedSide = kFixed ? p.fixedSide : 0;
  const int n = b.n;
#pragma GCC ivdep
  for (int k = 0; k < n; ++k) {
    const R ri = b.ri[k], mi = b.mi[k];
    const R Ii = R(0.4) * mi * ri * ri;
    const contact::ContactState<R> s =
        pairState<R, kSpin>(Vec3d{b.dx[k], b.dy[k], b.dz[k]}, b.d2[k], b.rs[k], V{b.vix[k], b.viy[k], b.viz[k]},
                            V{b.wix[k], b.wiy[k], b.wiz[k]}, ri, mi, Ii, V{b.vjx[k], b.vjy[k], b.vjz[k]},
                            V{b.wjx[k], b.wjy[k], b.wjz[k]}, b.rj[k], b.mj[k], rollingPair, fixedSide);
    const auto out = contact::hertzMindlin<kTangential, kRolling, false>(p, s, V{b.hx[k], b.hy[k], b.hz[k]}, dt);
    b.fx[k] = out.force.x, b.fy[k] = out.force.y, b.fz[k] = out.force.z;
    b.tx[k] = out.torque.x, b.ty[k] = out.torque.y, b.tz[k] = out.torque.z;
    b.ox[k] = out.history.x, b.oy[k] = out.history.y, b.oz[k] = out.history.z;
    b.overlap[k] = s.overlap;
    const V tj = kSpin ? contact::partnerTorque(out, s.n, b.rj[k] - R(0.5) * s.overlap) : zero3<R>();
    b.ux[k] = tj.x, b.uy[k] = tj.y, b.uz[k] = tj.z;
  }
}

// Applies the evaluated batch in its order, as ComputeForces::row (kOnce) applies each contact after evaluating it:
// the overlap check, the history stored, i's sums, the reaction on j; and each ended row's sums added to its particle
// where the row ended. Leaves the batch empty, the open row's sums kept.
template <class R, bool kTangential, bool kRolling>
inline void applyBatch(ContactBatch<R>& b, const ForceArgs<R>& a) {
  using V = Vec3<R>;
  constexpr bool kSpin = kTangential || kRolling;
  int end = 0;
  for (int k = 0;; ++k) {
    for (; end < b.ends && b.endAt[end] == k; ++end) {
      const Index i = b.endParticle[end];
      a.force[i] += b.f;
      a.torque[i] += b.tq;
      b.f = zero3<R>(), b.tq = zero3<R>();
    }
    if (k == b.n) break;
    const Index i = b.i[k], j = b.j[k];
    const R ri = b.ri[k], rj = b.rj[k];
    if (b.overlap[k] > R(a.maxOverlap) * (ri < rj ? ri : rj)) {
      flagDeepOverlap(a.cond, i);
      flagDeepOverlap(a.cond, j);  // as j's own evaluation would
    }
    if constexpr (kTangential) {
      const int slot = b.slot[k];
      const V history{b.ox[k], b.oy[k], b.oz[k]};
      if (slot == kPoolSlot) {
        if (b.entry[k] >= 0) a.pool.disp[b.entry[k]] = history;
      } else if (slot >= 0) {
        a.histLayout.at(a.histDisp, i)[slot] = history;
      }
      *b.slotByte[k] = std::int8_t(slot);
    }
    const V force{b.fx[k], b.fy[k], b.fz[k]};
    b.f += force;
    if constexpr (kSpin) b.tq += V{b.tx[k], b.ty[k], b.tz[k]};
    a.force[j] -= force;
    if constexpr (kSpin) a.torque[j] += V{b.ux[k], b.uy[k], b.uz[k]};
  }
  b.n = 0, b.ends = 0, b.pair = -1;
}

// One slab of ComputePairsOnce, batched: ComputeForces::row<kTangential, kRolling, false, kOnce = true> for each of its
// particles in ascending order, the contacts evaluated by batches.
template <class R, bool kFixed, bool kTangential, bool kRolling>
inline void batchedSlab(const ComputeForces<R, false, kFixed>& pairs, const Index* slabItems, Index from, Index to,
                        const std::uint32_t* owned) {
  using V = Vec3<R>;
  constexpr bool kSpin = kTangential || kRolling;
  const ForceArgs<R>& a = pairs.a;
  const Vec3d* __restrict__ pos = a.pos;
  const V* __restrict__ vel = a.vel;
  const V* __restrict__ omega = a.omega;
  const R* __restrict__ radius = a.radius;
  const R* __restrict__ mass = a.mass;
  const std::int32_t* __restrict__ material = a.material;
  const Gid* __restrict__ gid = a.gid;
  const std::size_t col = a.nbrLayout.stride();
  const R dt = R(a.dt);
  ContactBatch<R> b;
  const auto flush = [&] {
    if (b.n) evaluateBatch<R, kTangential, kRolling, kFixed>(b, a.params[b.pair], dt);
    applyBatch<R, kTangential, kRolling>(b, a);
  };
  for (Index k = from; k < to; ++k) {
    const Index i = slabItems[k];
    const std::size_t row = a.nbrLayout.base(i);
    const Index* __restrict__ nbr = a.nbr + row;
    std::int8_t* nbrSlot = a.nbrSlot + row;
    const std::int64_t rowPairs = std::int64_t(material[i]) * a.numMaterials;
    const ContactParams* params = a.params + rowPairs;
    typename ComputeForces<R, false, kFixed>::RowHistory h = pairs.history(i);
    const Vec3d xi = pos[i];
    const V vi = vel[i], wi = kSpin ? omega[i] : zero3<R>();
    const R ri = radius[i], mi = mass[i];
    const std::uint32_t count = owned[i];
    for (std::uint32_t e = 0; e < count; ++e) {
      const Index j = nbr[e * col];
      const Vec3d d = pos[j] - xi;
      const R rj = radius[j];
      const double rs = double(ri) + double(rj);
      const double d2 = norm2(d);
      int slot = -1;
      std::int32_t entry = -1;
      V xiOld = zero3<R>();
      if (!pairs.template admit<kTangential, false>(h, nbrSlot + e * col, j, d2, rs, ri, rj, params, material, gid, slot,
                                                    entry, xiOld))
        continue;
      const std::int64_t pair = rowPairs + material[j];
      if (b.n == ContactBatch<R>::kSize || (b.n && pair != b.pair)) flush();
      b.pair = pair;
      const int c = b.n++;
      b.dx[c] = d.x, b.dy[c] = d.y, b.dz[c] = d.z, b.d2[c] = d2, b.rs[c] = rs;
      b.vix[c] = vi.x, b.viy[c] = vi.y, b.viz[c] = vi.z, b.wix[c] = wi.x, b.wiy[c] = wi.y, b.wiz[c] = wi.z;
      b.ri[c] = ri, b.mi[c] = mi;
      const V vj = vel[j], wj = kSpin ? omega[j] : zero3<R>();
      b.vjx[c] = vj.x, b.vjy[c] = vj.y, b.vjz[c] = vj.z, b.wjx[c] = wj.x, b.wjy[c] = wj.y, b.wjz[c] = wj.z;
      b.rj[c] = rj, b.mj[c] = mass[j];
      b.hx[c] = xiOld.x, b.hy[c] = xiOld.y, b.hz[c] = xiOld.z;
      b.i[c] = i, b.j[c] = j, b.slot[c] = slot, b.entry[c] = entry, b.slotByte[c] = nbrSlot + e * col;
    }
    pairs.template endRow<kTangential, true>(i, h, owned);
    if (b.ends == ContactBatch<R>::kEnds) flush();
    b.endParticle[b.ends] = i, b.endAt[b.ends] = b.n, ++b.ends;
  }
  flush();
}

}  // namespace pflow::compute::kernels
