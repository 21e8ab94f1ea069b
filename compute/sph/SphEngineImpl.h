// The SPH engine over any executor and precision: the phases as launches of the kernels in SphKernels.h.
// Instantiated for the OpenMP executor in SphCpuEngine.cc and for CUDA in SphCudaEngine.cu, each in float
// and double (positions are double in both). What it shares with the DEM engine: the executor, the field
// store and its row operations (compute/particles), the cell hash and counting sort (compute/neighbor).
#pragma once
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "compute/neighbor/NeighborKernels.h"
#include "compute/particles/FieldRows.h"
#include "compute/particles/FieldStore.h"
#include "compute/sph/SphEngine.h"
#include "compute/sph/SphFields.h"
#include "compute/sph/SphKernels.h"
#include "compute/sph/SphMdbcKernels.h"
#include "compute/sph/SphStepKernels.h"

namespace pflow::compute::sph {

template <class Exec, class R>
class SphEngineImpl final : public ForwardDistributedRows<SphEngine, LocalRows<Exec, FieldStore<SphFieldSet, R>>> {
 public:
  using Store = FieldStore<SphFieldSet, R>;
  using RateSet = SphEngine::RateSet;
  using V = Vec3<R>;

  explicit SphEngineImpl(SphSetup s)
      : m_exec(s.threads), m_mem(m_exec.memory()), m_fields(m_mem), m_rows(m_exec, m_mem, m_fields), m_setup(std::move(s)) {
    init();
  }

  std::string executorDescription() const override { return m_exec.description(); }
  const char* precisionName() const override { return sizeof(R) == 4 ? "float" : "double"; }
  std::size_t size() const override { return m_owned; }
  std::size_t ghosts() const override { return m_n - m_owned; }
  std::size_t deviceBytes() const override { return m_mem.bytesInUse(); }
  void fence() const override { m_exec.synchronize(); }

  void sortByCell() override {
    // Ghosts are dropped before a rebuild (DistributedRows): only owned particles are sorted.
    const CellGrid& g = m_setup.grid;
    dropGhosts();
    sizeLocalBuffers();
    m_exec.forEach(m_n, compute::kernels::CellKey{g, ptr<SphField::Position>(), m_cellKey.as<std::uint32_t>()});
    m_exec.sortByKey(m_cellKey.as<std::uint32_t>(), m_n, g.numCells(), m_perm.as<Index>(), m_cellStart.as<Index>());
    if (m_setup.canonicalOrder)  // within each cell by global id (the ids of the rows before the reorder)
      m_exec.forEach(g.numCells(), kernels::SortCellByGid{m_cellStart.as<Index>(), m_perm.as<Index>(), cptr<SphField::Gid>(), 0});
    m_rows.reorder(m_perm.as<Index>(), m_n);
    // The skin's reference and each particle's home cell: sized here only (the ghosts that follow must not
    // reallocate it).
    if (m_ref.bytes() < std::size_t(m_n) * sizeof(Vec3d)) m_ref.resize(std::size_t(m_n) * sizeof(Vec3d) * 5 / 4 + sizeof(Vec3d));
    m_mem.copyWithin(m_ref.data(), ptr<SphField::Position>(), std::size_t(m_n) * sizeof(Vec3d));
    m_wetStale = true;
    m_masksStale = true;
    m_atHome = true;
    m_sorted = true;
  }

  // ---- distributed runs (DistributedRows): LocalRows's operations (ForwardDistributedRows), and these ----
  ParticleSnapshot snapshot(std::int64_t step, double time, const std::vector<std::string>& fields) const override {
    return m_rows.snapshot(step, time, m_owned, fields);
  }
  void setGhosts(const std::vector<PackedRows>& blocks) override {
    m_rows.setGhosts(blocks, m_setup.grid, [this] { return cptr<SphField::Position>(); });
    if (m_setup.canonicalOrder)
      m_rows.orderGhostCells(m_setup.grid.numCells(), [&](const Index* cellStart, Index* items) {
        return kernels::SortCellByGid{cellStart, items, cptr<SphField::Gid>(), m_owned};
      });
    sizeLocalBuffers();
    splitBoundary();
    m_wetStale = true;
    m_masksStale = true;
  }
  bool cellKeys(const CellGrid& grid, std::vector<std::uint32_t>& cells) override {
    sizeLocalBuffers();
    cells.resize(m_owned);
    if (m_owned == 0) return true;
    m_exec.forEach(m_owned, compute::kernels::CellKey{grid, cptr<SphField::Position>(), m_cellKey.as<std::uint32_t>()});
    m_mem.copyToHost(cells.data(), m_cellKey.data(), std::size_t(m_owned) * sizeof(std::uint32_t));
    return true;
  }

  std::vector<double> costWeights() override {
    std::vector<double> w;
    if (!m_sorted) {  // the scene's partition's weights, until the first sort
      w = m_setup.costWeight;
      return w;
    }
    if (m_wetStale) markWet();
    std::vector<std::int32_t> kind(m_owned);
    std::vector<std::uint8_t> wet(m_owned);
    m_mem.copyToHost(kind.data(), cptr<SphField::Kind>(), std::size_t(m_owned) * sizeof(std::int32_t));
    m_mem.copyToHost(wet.data(), m_wet.data(), std::size_t(m_owned));
    w.resize(m_owned);
    for (Index i = 0; i < m_owned; ++i) w[i] = sphCostWeight(kind[i] == kernels::kFluid, wet[i] != 0);
    return w;
  }
  void dropGhosts() override {
    m_numBoundary = 0;
    m_rows.dropGhosts();
    m_masksStale = true;
  }

  void computeRates(RateSet set) override {
    const bool ghosts = m_n > m_owned;
    if (m_wetStale) markWet();
    // How far a particle may be from the cell it is listed in (both passes' pruning): half the skin, widened.
    const double margin = 0.5 * m_setup.skin * 1.001 + 1e-5 * m_setup.grid.cellSize;
    // mDBC: the boundary particles' density from the fluid at their ghost nodes, before the pass reads it (one process
    // only: SphSimulation::create), over the wet boundary particles listed by markWet.
    if (m_setup.mdbc.on && set != RateSet::kBoundary && m_mdbcCount > 0)
      m_exec.forEach(m_mdbcCount, kernels::MdbcDensity<R>{m_setup.grid, m_cellStart.as<Index>(), cptr<SphField::Position>(),
                                                          cptr<SphField::Kind>(), cptr<SphField::Mass>(), m_mdbcList.as<Index>(),
                                                          m_kernel, m_eos, m_setup.mdbc, m_setup.rho0, m_setup.maxDensity, margin,
                                                          ptr<SphField::Density>(), ptr<SphField::Pressure>()});
    // The packed rows the pass reads: the owned ones before the interior pass (the ghosts are still travelling),
    // the ghosts before the boundary one.
    const Index packFrom = set == RateSet::kBoundary ? m_owned : 0;
    const Index packTo = set == RateSet::kInterior && ghosts ? m_owned : m_n;
    packRates(packFrom, packTo);
    kernels::Interact<R> k{m_setup.grid, m_cellStart.as<Index>(), m_ref.as<Vec3d>(), m_packRow.as<kernels::RateRow<R>>(),
                           m_packState.as<kernels::RateState<R>>(), m_packPm.as<kernels::RatePm<R>>(), m_kernel, m_pair,
                           vcast<R>(m_setup.gravity), ptr<SphField::Acceleration>(), ptr<SphField::DensityRate>(),
                           ptr<SphField::ViscousRate>()};
    kernels::RateFields<R> f{m_setup.grid, m_cellStart.as<Index>(), m_ref.as<Vec3d>(), cptr<SphField::Position>(), cptr<SphField::Velocity>(),
                             cptr<SphField::Density>(), cptr<SphField::Pressure>(), cptr<SphField::Mass>(), cptr<SphField::Kind>()};
    if (ghosts) {
      k.ghostCellStart = f.ghostCellStart = m_rows.ghostCellStart();
      k.ghostItems = f.ghostItems = m_rows.ghostItems();
      k.ghostBase = f.ghostBase = m_owned;
      // Ghosts are merged with the rows by id (CandidateWalk): in the canonical order of distributed runs, each
      // cell's rows and ghosts are sorted by it (SortCellByGid).
      k.gid = cptr<SphField::Gid>();
      if (m_setup.canonicalOrder) f.gid = k.gid;
    }
    k.wet = m_wet.as<std::uint8_t>();
    k.skipBoundary = m_setup.mdbc.on;  // the boundary's rates are not used (Interact::skipBoundary; kept by the pairs once)
    // The step loop computes rates only while no particle has moved half the skin since the sort (SphSimulation::rates).
    k.margin = R(margin);
    // The hit masks (SphSetup::hitMasks): marked by the first pass after a sort while the positions are still those
    // of the sort (not after a resume's sort that a step followed: walked until the next sort), read by the passes
    // until the next sort. Not on a rank with ghosts: the masks name a candidate by its place in a row's one range.
    const bool whole = set == RateSet::kAll || (m_numBoundary == 0 && set == RateSet::kInterior);  // one pass over every row
    if (m_setup.hitMasks && whole && !ghosts && m_setup.grid.reach == 2) {
      const Index n = std::max<Index>(m_owned, 1);
      if (m_masksStale && m_atHome) {
        if (m_maskRows.bytes() < std::size_t(n) * 8) m_maskRows.resize(std::size_t(n) * 10);
        if (m_masks.bytes() < std::size_t(n) * 4 * kernels::kMaskSlots) m_masks.resize(std::size_t(n) * 5 * kernels::kMaskSlots);
        const double reach = double(m_kernel.support()) + m_setup.skin;
        k.markMasks = m_masks.as<std::uint32_t>();
        k.markRows = m_maskRows.as<std::uint64_t>();
        k.markCut2 = R(reach * reach * (1 + 1e-4));
        m_masksStale = false;
      } else if (!m_masksStale) {
        k.masks = m_masks.as<std::uint32_t>();
        k.maskRows = m_maskRows.as<std::uint64_t>();
      }
      k.maskLayout = Exec::kColumnMajorLists ? ListLayout::columnMajor(n) : ListLayout::rowMajor(kernels::kMaskSlots);
    }
    const bool mirror = m_setup.mirror.any;
    if (whole) {
      using P = kernels::RatePass;
      const bool twoPhase = m_setup.twoPhaseWalk.value_or(Exec::kLockstepLanes && sizeof(R) == 4) && m_setup.grid.reach <= 2;
      // The pairs once (SphSetup::pairsOnce): one process, no ghosts, the walk (not the masks), any order of the sums.
      m_pairsOnce = !m_setup.hitMasks && !ghosts && !m_setup.canonicalOrder &&
                    m_setup.pairsOnce.value_or(!m_setup.reproducible && Exec::kLockstepLanes && sizeof(R) == 4);
      if (m_pairsOnce) {
        const std::size_t bytes = std::size_t(std::max<Index>(m_owned, 1)) * sizeof(kernels::RateSum<R>);
        if (m_sums.bytes() < bytes) {  // zero once; FinishRates zeroes what it reads
          m_sums.resize(bytes + bytes / 4);
          m_mem.fillBytes(m_sums.data(), 0, m_sums.bytes());
        }
        k.sums = m_sums.as<kernels::RateSum<R>>();
        if (twoPhase) m_exec.forEach(m_owned, kernels::InteractPass<R, P::kTwoPhase, true>{k});
        else m_exec.forEach(m_owned, kernels::InteractPass<R, P::kWalk, true>{k});
        m_exec.forEach(m_owned, kernels::FinishRates<R>{k.sums, cptr<SphField::Kind>(), k.gravity, k.acc, k.drho});
        m_lastPass = twoPhase ? "twophase_once" : "walk_once";
      } else if (k.markMasks) {
        m_exec.forEach(m_owned, kernels::InteractPass<R, P::kMark>{k});
        m_lastPass = "mark";
      } else if (k.masks) {
        m_exec.forEach(m_owned, kernels::InteractPass<R, P::kMasks>{k});
        m_lastPass = "masks";
      } else if (twoPhase) {
        m_exec.forEach(m_owned, kernels::InteractPass<R, P::kTwoPhase>{k});
        m_lastPass = "twophase";
      } else {
        m_exec.forEach(m_owned, kernels::InteractPass<R, P::kWalk>{k});
        m_lastPass = "walk";
      }
      if (mirror) m_exec.forEach(m_owned, kernels::MirrorImages<R>{k, f, m_setup.mirror});
      return;
    }
    m_pairsOnce = false;
    m_lastPass = "walk";
    // The list splitBoundary made: boundary rows first, then interior ones.
    const Index* list = m_split.as<Index>() + (set == RateSet::kBoundary ? 0 : m_numBoundary);
    const Index count = set == RateSet::kBoundary ? m_numBoundary : m_owned - m_numBoundary;
    m_exec.forEach(count, compute::kernels::OverList<kernels::InteractPass<R, kernels::RatePass::kWalk>>{{k}, list});
    if (mirror) m_exec.forEach(count, compute::kernels::OverList<kernels::MirrorImages<R>>{kernels::MirrorImages<R>{k, f, m_setup.mirror}, list});
  }

  void setRatePasses(bool hitMasks, bool twoPhaseWalk, bool pairsOnce) override {
    m_setup.hitMasks = hitMasks;
    m_setup.twoPhaseWalk = twoPhaseWalk;
    m_setup.pairsOnce = pairsOnce;
    m_masksStale = true;
  }
  bool pairsOnce() const override { return m_pairsOnce; }
  const char* lastRatePass() const override { return m_lastPass; }

  double maxInverseStep() const override {
    return m_exec.maxOf(m_owned, kernels::InverseStep<R>{cptr<SphField::Acceleration>(), cptr<SphField::ViscousRate>(),
                                                         cptr<SphField::Kind>(), m_setup.h, m_setup.c0});
  }

  double predictor(double dt) override {
    m_atHome = false;
    return m_exec.maxOf(m_owned, kernels::Predictor<R>{stepArgs(dt)});
  }

  Status corrector(double dt, double& moved2) override {
    m_exec.forEach(1, compute::kernels::ResetConditions{m_cond.as<Conditions>()});
    m_atHome = false;
    moved2 = m_exec.maxOf(m_owned, kernels::Corrector<R>{stepArgs(dt)});
    return checked();
  }

  Status verlet(double dt, double dtBefore, double& moved2) override {
    m_exec.forEach(1, compute::kernels::ResetConditions{m_cond.as<Conditions>()});
    m_atHome = false;
    moved2 = m_exec.maxOf(m_owned, kernels::VerletStep<R>{stepArgs(dt), dtBefore});
    return checked();
  }

  double kickDrift(double dt) override {
    m_atHome = false;
    return m_exec.maxOf(m_owned, kernels::KickDrift<R>{stepArgs(dt)});
  }

  Status kick(double dt) override {
    m_exec.forEach(1, compute::kernels::ResetConditions{m_cond.as<Conditions>()});
    m_exec.forEach(m_owned, kernels::Kick<R>{stepArgs(dt)});
    return checked();
  }

  double fluidReach(Vec3d direction) const override {
    // Measured from the grid's far corner against `direction`, so every value is >= 0 (maxOf's floor).
    const CellGrid& g = m_setup.grid;
    const Vec3d hi = g.lo + g.cellSize * Vec3d{double(g.nx), double(g.ny), double(g.nz)};
    const Vec3d base{direction.x >= 0 ? g.lo.x : hi.x, direction.y >= 0 ? g.lo.y : hi.y, direction.z >= 0 ? g.lo.z : hi.z};
    if (m_owned == 0) return 0;
    return m_exec.maxOf(m_owned, kernels::FluidReach{cptr<SphField::Position>(), cptr<SphField::Kind>(), direction, base}) + dot(base, direction);
  }

  void sample(const std::vector<Vec3d>& points, std::vector<double>& fraction, std::vector<double>& pressure) const override {
    const std::size_t n = points.size();
    fraction.assign(n, 0.0);
    pressure.assign(n, 0.0);
    if (!n) return;
    const int side = 2 * m_setup.grid.reach + 1, rows = side * side;
    const std::size_t items = n * std::size_t(rows);
    // The points (uploaded again only when they change: a run samples the same ones every time), the sums, the rows'.
    const std::size_t bytes = n * sizeof(Vec3d) + 2 * n * sizeof(double) + 2 * items * sizeof(double);
    if (m_samples.bytes() < bytes) {
      m_samples.resize(bytes);
      m_samplePoints.clear();
    }
    auto* pts = m_samples.as<Vec3d>();
    auto* sums = reinterpret_cast<double*>(pts + n);  // n fractions, then n pressures
    double* partial = sums + 2 * n;
    if (m_samplePoints.size() != n || std::memcmp(m_samplePoints.data(), points.data(), n * sizeof(Vec3d)) != 0) {
      m_mem.copyFromHost(pts, points.data(), n * sizeof(Vec3d));
      m_samplePoints = points;
    }
    m_exec.forEach(Index(items), kernels::SampleRows<R>{m_setup.grid, m_cellStart.as<Index>(), cptr<SphField::Position>(),
                                                        cptr<SphField::Density>(), cptr<SphField::Pressure>(), cptr<SphField::Mass>(),
                                                        cptr<SphField::Kind>(), m_kernel, pts, rows, partial});
    m_exec.forEach(Index(n), kernels::SampleSum{partial, rows, sums, sums + n});
    m_sampleHost.resize(2 * n);  // one copy back for both sums
    m_mem.copyToHost(m_sampleHost.data(), sums, 2 * n * sizeof(double));
    std::copy(m_sampleHost.begin(), m_sampleHost.begin() + std::ptrdiff_t(n), fraction.begin());
    std::copy(m_sampleHost.begin() + std::ptrdiff_t(n), m_sampleHost.end(), pressure.begin());
  }

  ParticleSnapshot stateArrays(std::int64_t step, double time) const override {
    return m_rows.stateArrays(step, time, m_owned, kMigrate | kCheckpoint);
  }
  Status loadState(const ParticleSnapshot& s, std::vector<double> costWeight = {}) override {
    m_setup.costWeight = std::move(costWeight);
    m_sorted = false;
    m_fields.allocate(std::max<Index>(Index(s.n), 1), 0, 0, false);
    m_n = m_owned = Index(s.n);
    Status st = m_rows.loadState(s, kMigrate | kCheckpoint);
    sizeLocalBuffers();
    m_wetStale = true;
    m_masksStale = true;
    m_atHome = false;
    return st;
  }

  SphProbeState probe(Index i) const override {
    SphProbeState s;
    if (i >= m_owned) return s;
    V v;
    R rho, p;
    std::int32_t kind;
    m_mem.copyToHost(&s.gid, cptr<SphField::Gid>() + i, sizeof s.gid);
    m_mem.copyToHost(&s.position, cptr<SphField::Position>() + i, sizeof s.position);
    m_mem.copyToHost(&v, cptr<SphField::Velocity>() + i, sizeof v);
    m_mem.copyToHost(&rho, cptr<SphField::Density>() + i, sizeof rho);
    m_mem.copyToHost(&p, cptr<SphField::Pressure>() + i, sizeof p);
    m_mem.copyToHost(&kind, cptr<SphField::Kind>() + i, sizeof kind);
    s.velocity = vcast<double>(v);
    s.density = double(rho);
    s.pressure = double(p);
    s.fluid = kind == kernels::kFluid;
    return s;
  }

 private:
  using Rows = LocalRows<Exec, Store>;
  Rows& rows() override { return m_rows; }
  const Rows& rows() const override { return m_rows; }
  void localRowsChanged() override {
    sizeLocalBuffers();
    m_masksStale = true;
    m_atHome = false;
  }
  template <SphField F> typename Store::template Type<F>* ptr() { return m_fields.template ptr<F>(); }
  template <SphField F> const typename Store::template Type<F>* cptr() const { return m_fields.template ptr<F>(); }

  // After the ghosts arrive: which owned particles have a ghost in the cells within reach (their rates wait for the halo),
  // as one list with those first (m_split, m_numBoundary).
  void splitBoundary() {
    m_numBoundary = 0;
    if (m_n == m_owned || m_owned == 0) return;
    const std::size_t n = m_owned;
    if (m_split.bytes() < n * sizeof(Index)) m_split.resize(n * sizeof(Index) + n * sizeof(Index) / 4);
    if (m_splitFlag.bytes() < 2 * n * sizeof(std::uint32_t)) m_splitFlag.resize(2 * n * sizeof(std::uint32_t) + n * sizeof(std::uint32_t) / 2);
    std::uint32_t* flag = m_splitFlag.as<std::uint32_t>();
    std::uint32_t* scan = flag + n;
    m_exec.forEach(m_owned, kernels::MarkNearGhosts{m_setup.grid, ptr<SphField::Position>(), m_rows.ghostCellStart(), flag});
    m_numBoundary = Index(m_exec.exclusiveScan(flag, scan, m_owned));
    m_exec.forEach(m_owned, compute::kernels::SplitByFlag{flag, scan, m_numBoundary, m_split.as<Index>()});
  }

  // Rows [from, to) of the packed arrays the rates pass reads (PackRates), sized for every local row.
  void packRates(Index from, Index to) {
    if (to <= from) return;
    const std::size_t n = std::max<Index>(1, m_n);
    auto atLeast = [](Buffer& b, std::size_t bytes) {
      if (b.bytes() < bytes) b.resize(bytes + bytes / 4);
    };
    atLeast(m_packRow, n * sizeof(kernels::RateRow<R>));
    atLeast(m_packState, n * sizeof(kernels::RateState<R>));
    atLeast(m_packPm, n * sizeof(kernels::RatePm<R>));
    kernels::PackRates<R> pack{m_setup.grid, m_ref.as<Vec3d>(), m_n > m_owned ? m_rows.ghostKeys() : nullptr, m_owned,
                               cptr<SphField::Position>(), cptr<SphField::Velocity>(), cptr<SphField::Density>(),
                               cptr<SphField::Pressure>(), cptr<SphField::Mass>(), cptr<SphField::Kind>(),
                               m_packRow.as<kernels::RateRow<R>>(), m_packState.as<kernels::RateState<R>>(),
                               m_packPm.as<kernels::RatePm<R>>()};
    m_exec.forEach(to - from, compute::kernels::Offset<kernels::PackRates<R>>{pack, from});
  }

  // Which boundary particles can have fluid neighbours until the next sort (MarkWet), after each sort and halo.
  void markWet() {
    if (m_wet.bytes() < std::max<std::size_t>(1, m_owned)) m_wet.resize(std::max<std::size_t>(1, m_owned) * 5 / 4 + 1);
    kernels::MarkWet w{m_setup.grid, m_cellStart.as<Index>(), m_ref.as<Vec3d>(), cptr<SphField::Kind>()};
    if (m_n > m_owned) {
      w.ghostCellStart = m_rows.ghostCellStart();
      w.ghostItems = m_rows.ghostItems();
      w.ghostBase = m_owned;
    }
    w.wet = m_wet.as<std::uint8_t>();
    m_exec.forEach(m_owned, w);
    m_wetStale = false;
    if (m_setup.mdbc.on) {  // the mDBC pass's list: the wet boundary particles, in row order
      // The flags and their scan in the sort's key and permutation buffers (sized for every local row, unused between
      // sorts); the list holds those flagged only.
      std::uint32_t* flag = m_cellKey.as<std::uint32_t>();
      Index* scan = m_perm.as<Index>();
      m_exec.forEach(m_owned, kernels::MdbcFlag{cptr<SphField::Kind>(), m_wet.as<std::uint8_t>(), flag});
      m_mdbcCount = Index(m_exec.exclusiveScan(flag, scan, m_owned));  // the count: one read back a sort
      if (m_mdbcList.bytes() < std::size_t(std::max<Index>(m_mdbcCount, 1)) * sizeof(Index))
        m_mdbcList.resize(std::size_t(std::max<Index>(m_mdbcCount, 1)) * sizeof(Index) * 5 / 4);
      m_exec.forEach(m_owned, compute::kernels::CompactFlagged{flag, scan, m_mdbcList.as<Index>()});
    }
  }

  // Per-particle work buffers sized for the local rows (kept when big enough).
  void sizeLocalBuffers() {
    auto atLeast = [](Buffer& b, std::size_t bytes) {
      if (b.bytes() < bytes) b.resize(bytes + bytes / 4);
    };
    const std::size_t n = std::max<Index>(1, m_n);
    atLeast(m_cellKey, n * sizeof(std::uint32_t));
    atLeast(m_perm, n * sizeof(Index));
  }

  void init() {
    const SphSetup& s = m_setup;
    m_n = m_owned = Index(s.position.size());
    m_fields.allocate(m_n, 0, 0, false);
    auto put = [&]<SphField F, class T>(std::integral_constant<SphField, F>, const std::vector<T>& src) {
      using Dst = typename Store::template Type<F>;
      std::vector<Dst> v(m_n);
      for (Index i = 0; i < m_n; ++i) {
        if (src.empty()) std::memset(static_cast<void*>(&v[i]), 0, sizeof(Dst));
        else if constexpr (std::is_same_v<T, Vec3d> && !std::is_same_v<Dst, Vec3d>) v[i] = vcast<R>(src[i]);
        else v[i] = Dst(src[i]);
      }
      m_mem.copyFromHost(m_fields.buffer(F).data(), v.data(), v.size() * sizeof(Dst));
    };
    std::vector<Gid> gids(m_n);
    for (Index i = 0; i < m_n; ++i) gids[i] = s.gid.empty() ? Gid(i) : s.gid[i];
    const std::vector<Vec3d> none3;
    const std::vector<double> none;
    put(std::integral_constant<SphField, SphField::Position>{}, s.position);
    put(std::integral_constant<SphField, SphField::Velocity>{}, s.velocity);
    put(std::integral_constant<SphField, SphField::Density>{}, s.density);
    put(std::integral_constant<SphField, SphField::Mass>{}, s.mass);
    put(std::integral_constant<SphField, SphField::Kind>{}, s.kind);
    put(std::integral_constant<SphField, SphField::Gid>{}, gids);
    put(std::integral_constant<SphField, SphField::Acceleration>{}, none3);
    put(std::integral_constant<SphField, SphField::DensityRate>{}, none);
    put(std::integral_constant<SphField, SphField::ViscousRate>{}, none);
    put(std::integral_constant<SphField, SphField::Position0>{}, s.position);
    put(std::integral_constant<SphField, SphField::Velocity0>{}, s.velocity);
    put(std::integral_constant<SphField, SphField::Density0>{}, s.density);

    m_kernel = Kernel<R>::make(s.kernel, s.dimension, s.h);
    m_eos = Tait<R>::make(s.rho0, s.c0, s.gamma);
    m_pair.alpha = R(s.alpha);
    m_pair.nu = R(s.nu);
    m_pair.delta = R(s.delta);
    m_pair.eta2 = R(0.01 * s.h * s.h);
    m_pair.h = R(s.h);
    m_pair.c0 = R(s.c0);
    m_pair.hydrostatic = s.hydrostaticDiffusion;
    m_pair.gOverC2 = vcast<R>((1.0 / (s.c0 * s.c0)) * s.gravity);
    m_pair.rho0 = R(s.rho0);
    m_exec.forEach(m_n, kernels::EquationOfState<R>{ptr<SphField::Density>(), ptr<SphField::Pressure>(), m_eos});

    sizeLocalBuffers();
    m_cellStart.resize((std::size_t(s.grid.numCells()) + 1) * sizeof(Index));
  }

  kernels::StepArgs<R> stepArgs(double dt) {
    kernels::StepArgs<R> a{ptr<SphField::Position>(), ptr<SphField::Velocity>(), ptr<SphField::Density>(), ptr<SphField::Pressure>(),
                           ptr<SphField::Acceleration>(), ptr<SphField::DensityRate>(), ptr<SphField::Kind>(),
                           ptr<SphField::Position0>(), ptr<SphField::Velocity0>(), ptr<SphField::Density0>(), m_ref.as<Vec3d>(),
                           m_eos, dt, R(m_setup.rho0), R(m_setup.minDensity), R(m_setup.maxDensity)};
    a.checkBox = m_setup.checkBox;
    a.boxLo = m_setup.boxLo;
    a.boxHi = m_setup.boxHi;
    a.mirror = m_setup.mirror;
    a.extrapolatedBoundary = m_setup.mdbc.on;
    a.cond = m_cond.as<Conditions>();
    return a;
  }

  // What the step's checks (checkState) flagged, as an error naming the first particle of each kind.
  Status checked() const {
    Conditions c;
    m_mem.copyToHost(&c, m_cond.data(), sizeof c);
    if (c.flags & kNonFinite) return failure("non-finite", c.badParticle, "has a non-finite position, velocity or density");
    if (c.flags & kDensityOutOfRange)
      return failure("density out of range", c.densityParticle,
                     "left the density bounds [" + std::to_string(m_setup.minDensity) + ", " + std::to_string(m_setup.maxDensity) +
                         "] kg/m^3 (sph.density_bounds)");
    if (c.flags & kLeftDomain)
      return failure("leak", c.outsideParticle,
                     "is outside the tank's walls below their top: it passed through a wall (dt too large, or too few "
                     "wall layers), or spilled over an open top (the tank is too low for this flow)");
    return Status::ok();
  }

  // "<what>: fluid particle G at (x, y, z) m, speed v m/s, density rho kg/m^3 <why>" (the step and time are
  // added by the simulation).
  Status failure(const char* what, Index i, const std::string& why) const {
    const SphProbeState p = probe(i);
    char buf[384];
    std::snprintf(buf, sizeof buf, "%s: %s particle %llu at (%.6g, %.6g, %.6g) m, speed %.4g m/s, density %.6g kg/m^3, ", what,
                  p.fluid ? "fluid" : "boundary", (unsigned long long)p.gid, p.position.x, p.position.y, p.position.z,
                  norm(p.velocity), p.density);
    return Status(StatusCode::kNumerical, buf + why);
  }

  Exec m_exec;
  MemorySpace& m_mem;
  Store m_fields;
  LocalRows<Exec, Store> m_rows;  // reorder, snapshots, migration, ghosts: driven by the SPH field table
  SphSetup m_setup;
  Index& m_n = m_rows.n;  // local rows: the owned particles, then ghosts (distributed runs)
  Index& m_owned = m_rows.owned;
  Kernel<R> m_kernel;
  Tait<R> m_eos;
  PairParams<R> m_pair;
  Buffer m_cellKey{m_mem, 0}, m_perm{m_mem, 0}, m_cellStart{m_mem, 0}, m_ref{m_mem, 0};
  Buffer m_cond{m_mem, sizeof(Conditions)};
  mutable Buffer m_samples{m_mem, 0};  // sample(): points, then fractions and pressures, then the rows' sums
  mutable std::vector<Vec3d> m_samplePoints;  // the points m_samples holds
  mutable std::vector<double> m_sampleHost;    // the sums as copied back
  Buffer m_split{m_mem, 0}, m_splitFlag{m_mem, 0};  // boundary rows, then interior ones (splitBoundary)
  Buffer m_wet{m_mem, 0};  // MarkWet, per owned particle
  Buffer m_mdbcList{m_mem, 0};  // mDBC: the wet boundary rows (m_mdbcCount of them; markWet)
  Index m_mdbcCount = 0;
  Buffer m_packRow{m_mem, 0}, m_packState{m_mem, 0}, m_packPm{m_mem, 0};  // PackRates, per local row
  Buffer m_sums{m_mem, 0};  // the pairs once's sums (RateSum), per owned row, zero between passes
  bool m_pairsOnce = false;  // the last rates pass evaluated each pair once
  const char* m_lastPass = "none";  // lastRatePass()
  bool m_wetStale = true;
  // Hit masks (computeRates): stale after every sort, halo and load.
  Buffer m_masks{m_mem, 0}, m_maskRows{m_mem, 0};
  bool m_masksStale = true;
  bool m_atHome = false;  // the positions are those of the last sort (m_ref): no integration step since
  bool m_sorted = false;  // cellStart and the wet flags exist from the first sortByCell
  Index m_numBoundary = 0;
};

}  // namespace pflow::compute::sph
