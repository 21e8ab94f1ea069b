// Engine over any executor and precision: the phases as launches of the kernel functors. Instantiated
// for the OpenMP executor in CpuEngine.cc and for CUDA in CudaEngine.cu, each in float and double
// (R: velocities, spins, forces, torques, radii, masses and history; positions are double in both).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "compute/dem/contact/ForceKernel.h"
#include "compute/dem/contact/HalfPairs.h"
#include "compute/dem/HistoryPoolStore.h"
#include "compute/dem/geometry/MeshKernels.h"
#include "compute/dem/integrate/VelocityVerlet.h"
#include "compute/neighbor/NeighborKernels.h"
#include "compute/particles/FieldRows.h"
#include "compute/dem/ParticleData.h"
#include "compute/dem/Engine.h"
#include "compute/dem/TimeStep.h"

namespace pflow::compute {


template <class Exec, class R>
class EngineImpl final : public ForwardDistributedRows<Engine, LocalRows<Exec, ParticleData<R>>> {
 public:
  using Engine::computeForces;
  using ForceSet = Engine::ForceSet;
  using V = Vec3<R>;

  explicit EngineImpl(EngineSetup s)
      : m_exec(s.threads), m_mem(m_exec.memory()), m_particles(m_mem), m_rows(m_exec, m_mem, m_particles), m_setup(std::move(s)),
        m_pool(m_exec, m_mem) {
    init();
  }

  std::string executorDescription() const override { return m_exec.description(); }
  const char* precisionName() const override { return sizeof(R) == 4 ? "float" : "double"; }
  std::size_t size() const override { return m_owned; }
  std::size_t ghosts() const override { return m_n - m_owned; }
  int historySlots() const override { return m_particles.contactSlots(); }
  int wallHistorySlots() const override { return m_particles.wallSlots(); }
  std::size_t deviceBytes() const override { return m_mem.bytesInUse(); }
  std::size_t devicePeakBytes() const override { return m_mem.peakBytes(); }

  double integrateFirstHalf(double dt) override {
    return m_exec.maxOf(m_owned, kernels::IntegrateFirstHalf<R>{integrateArgs(dt)});
  }

  void setMeshMotion(int mesh, const MeshMotionParams& motion) override {
    m_mem.copyFromHost(m_meshMotion.as<MeshMotionParams>() + mesh, &motion, sizeof motion);
    if (!m_meshMoves[std::size_t(mesh)]) m_meshMoves[std::size_t(mesh)] = true, listMovingTriangles();
  }
  // Only the moving meshes' triangles are moved (a funnel's gate, not the plate under it); a static mesh's stay where
  // they were made.
  double moveMeshes(double time) override {
    if (m_numMovingTri == 0) return 0.0;
    kernels::MoveTriangles move{m_triRef.as<Vec3d>(), m_triVerts.as<Vec3d>(), m_triRebuild.as<Vec3d>(),
                                m_triMesh.as<std::int32_t>(), m_meshMotion.as<MeshMotionParams>(), time};
    move.which = m_numMovingTri < m_numTri ? m_movingTri.as<Index>() : nullptr;
    const double moved = m_exec.maxOf(m_numMovingTri, move);
    m_trianglesMoved = moved > 0;  // since they were binned (a gate that slid away and stopped: no more binning)
    return moved;
  }

  void sortByCell(bool keepForces) override {
    // Ghosts are dropped before a rebuild (Engine.h): only owned particles are sorted.
    const CellGrid& g = m_setup.grid;
    m_n = m_owned;
    m_particles.resize(m_n);
    // The cell keys and the permutation live in the displacements since the last rebuild, dead from here until
    // buildContacts zeroes them (movedBytes); the sort's second buffers, then the reorder's scratch, are the forces'
    // memory (kRecomputed) unless they are kept.
    auto* key = m_moved.as<std::uint32_t>();
    auto* perm = reinterpret_cast<Index*>(m_moved.as<unsigned char>() + permOffset(m_n));
    m_exec.forEach(m_n, kernels::CellKey{g, m_particles.template ptr<Field::Position>(), key});
    Buffer& lent = m_particles.buffer(Field::Force);
    m_exec.sortByKeyLent(key, m_n, g.numCells(), perm, m_cellStart.as<Index>(), keepForces ? nullptr : lent.data(),
                         keepForces ? 0 : lent.bytes());
    m_rows.reorder(perm, m_n, keepForces);
  }

  // ---- distributed runs (DistributedRows): LocalRows's operations (ForwardDistributedRows), and these ----
  void setGhosts(const std::vector<PackedRows>& blocks) override {
    m_rows.setGhosts(blocks, m_setup.grid, [this] { return m_particles.template ptr<Field::Position>(); });
    sizeLocalBuffers();
  }
  void dropGhosts() override {
    m_numBoundary = 0;
    m_rows.dropGhosts();
  }
  void save(std::vector<std::byte>& out) const override {
    std::vector<Index> rows(m_owned);
    for (Index i = 0; i < m_owned; ++i) rows[i] = i;
    m_rows.pack(rows, {int(m_owned)}, kMigrate, out);
    savePool();
  }
  void restore(const std::vector<std::byte>& rows, Index count, int contactSlots, int wallSlots) override {
    m_particles.allocate(std::max<Index>(count, 1), contactSlots, wallSlots, m_particles.slotMajor());
    m_n = m_owned = 0;
    m_rows.unpack(rows.data(), count, kMigrate);
    m_owned = m_n;
    m_particles.resize(m_n);
    sizeLocalBuffers();
    restorePool();
  }
  ParticleSnapshot stateArrays(std::int64_t step, double time) const override {
    ParticleSnapshot s = m_rows.stateArrays(step, time, m_owned, kMigrate | kCheckpoint);
    mergePool(s);
    return s;
  }
  Status loadState(const ParticleSnapshot& s, int contactSlots, int wallSlots) override {
    m_particles.allocate(std::max<Index>(Index(s.n), 1), contactSlots, wallSlots, m_particles.slotMajor());
    m_n = m_owned = Index(s.n);
    m_particles.resize(m_n);
    Status st = m_rows.loadState(s, kMigrate | kCheckpoint);
    sizeLocalBuffers();
    clearPooled();  // a checkpoint holds every history inline
    return st;
  }
  void ensureSlots(int contactSlots, int wallSlots) override {
    if (contactSlots > m_particles.contactSlots()) m_particles.resizeSlots(Multiplicity::kContactSlots, contactSlots);
    if (wallSlots > m_particles.wallSlots()) m_particles.resizeSlots(Multiplicity::kWallSlots, wallSlots);
  }

  Status buildContacts() override {
    // Positions and vertices now are the reference for the skin criterion. The displacement since rebuild
    // is not a field of the table (sortByCell does not reorder it): valid because a sort is always
    // followed by this (Engine.h).
    m_mem.fillBytes(m_moved.data(), 0, m_moved.bytes());
    // Triangles are binned once, and again at a rebuild when any has moved since, from where they are now.
    if (m_numTri && (m_trianglesMoved || !m_binned)) {
      m_mem.copyWithin(m_triRebuild.data(), m_triVerts.data(), m_triVerts.bytes());
      binTriangles();
      m_binned = true;
    }
    // The candidate rows: counted, laid out from the counts, then filled by the same walk.
    resetConditions();
    kernels::BuildNeighbors<R> build{m_setup.grid, m_cellStart.as<Index>(),
                                     m_particles.template ptr<Field::Position>(), m_particles.template ptr<Field::Radius>(),
                                     m_particles.template ptr<Field::Gid>(),
                                     m_particles.template ptr<Field::HistoryPartner>(),
                                     m_particles.contactSlots(),
                                     m_particles.layout(Multiplicity::kContactSlots), m_setup.skin, {},
                                     nullptr, nullptr, rowCounts(), m_cond.as<Conditions>()};
    build.canonicalOrder = m_setup.canonicalOrder;
    build.upperOnly = halfPairs();
    if (m_n > m_owned) {
      build.ghostCellStart = m_rows.ghostCellStart();
      build.ghostItems = m_rows.ghostItems();
      build.ghostBase = m_owned;
    }
    build.countOnly = true;
    m_exec.forEach(m_owned, build);
    if (Status st = layOutRows(); !st.ok()) return st;
    build.countOnly = false;
    build.layout = nbrLayout();
    build.nbr = m_nbr.as<Index>();
    build.nbrSlot = m_nbrSlot.as<std::int8_t>();
    m_exec.forEach(m_owned, build);
    if (m_anyWalls) {  // no wall phases (ModelFlags::walls): no candidates to find
      // Planes: a bit mask a particle. Triangles: rows of exact length, counted, laid out, then filled.
      kernels::WallCandidates<R> walls{m_setup.grid, m_planes.as<PlaneParams>(), int(m_setup.planes.size()),
                                       m_numTri ? m_binStart.as<Index>() : nullptr, m_binItems.as<Index>(),
                                       m_triVerts.as<Vec3d>(), m_particles.template ptr<Field::Position>(),
                                       m_particles.template ptr<Field::Radius>(), m_setup.skin, nullptr, nullptr,
                                       m_planeMask.as<std::uint32_t>(), m_particles.template ptr<Field::WallKey>(),
                                       m_particles.wallSlots(), m_particles.layout(Multiplicity::kWallSlots),
                                       m_cond.as<Conditions>()};
      if (m_numTri) {
        walls.start = wallCandStarts(m_owned);
        walls.countOnly = true;
        m_exec.forEach(m_owned, walls);
        if (Status st = layOutWallCandidates(); !st.ok()) return st;
        walls.countOnly = false;
        walls.cand = m_wallCand.as<Index>();
      }
      m_exec.forEach(m_owned, walls);
    }
    if (m_pool.active())  // the pooled histories of the contacts that go on, into a fresh table
      m_pool.resolve(kernels::ResolvePool<R>{m_particles.template ptr<Field::Position>(), m_particles.template ptr<Field::Radius>(),
                                             m_particles.template ptr<Field::Gid>(), m_nbr.as<Index>(), m_nbrSlot.as<std::int8_t>(),
                                             nbrLayout(), m_particles.template ptr<Field::HistoryPooled>(), {}, {},
                                             m_cond.as<Conditions>(), halfPairs()},
                     m_owned);
    if (readConditions().flags & kNeighborMismatch)
      return Status(StatusCode::kInternal, "a candidate walk found other counts when filling its rows than when counting them");
    splitBoundary();
    if (Status st = pullHistoryToOwners(); !st.ok()) return st;
    return buildSlabs();
  }
  std::size_t boundaryParticles() const override { return m_numBoundary; }

  Status computeForces(double dt, double time, ForceSet set) override {
    if (set != ForceSet::kBoundary) resetConditions();
    if (m_recordLoads && set != ForceSet::kBoundary) m_mem.fillBytes(m_surfaceLoads.data(), 0, m_surfaceLoads.bytes());
    launchForces(dt, time, set, false);
    if (set == ForceSet::kInterior) return Status::ok();  // queued; the boundary pass reads the flags
    Conditions c = readConditions();
    // A particle behind a wall is also deep in it: the tunnelling is the cause to name.
    if (c.flags & kTunnelled) return tunnelError(c.tunnelParticle, dt);
    if (c.flags & kExcessiveOverlap) return deepOverlapError(c.deepParticle, dt);
    if (c.flags & kTooManyWallContacts)
      return Status(StatusCode::kResourceExhausted,
                    "a particle touches more than " + std::to_string(kMaxWallContacts) +
                        " wall faces at once; the mesh is finer than the particles, coarsen it");
    // Slots ran out: the forces are already exact (a new contact starts from zero displacement); grow
    // the slots and store the displacements that found no slot.
    for (;;) {
      // More contacts than the scene allows (simulation.max_contacts): a collapse, not a dense packing (checked
      // whatever the flags: a pool holds such contacts without kHistoryOverflow).
      if (int(c.neededHistory) > m_setup.maxContacts) return slotOverflowError(dt);
      if (!(c.flags & (kHistoryOverflow | kWallHistoryOverflow))) break;
      if (c.flags & kHistoryOverflow) {
        if (m_pool.active()) {  // the inline slots are at their cap: the pool takes the rest
          if (!m_pool.grow(m_cond.as<Conditions>()))
            return Status(StatusCode::kResourceExhausted, "the contact-history pool reached 2^30 entries");
        } else {
          // One spare slot (up to the cap): slots are carried by every particle, so headroom costs n times over.
          const int grown = m_pool.inlineSlots(
              std::max<int>(m_particles.contactSlots() + 1, std::min<int>(int(c.neededHistory) + 1, m_setup.maxContacts)));
          if (grown > 127)
            return Status(StatusCode::kResourceExhausted,
                          "a particle has " + std::to_string(c.neededHistory) + " simultaneous contacts, above the 127-slot limit");
          if (grown > m_particles.contactSlots()) m_particles.resizeSlots(Multiplicity::kContactSlots, grown);
          m_pool.enableAt(m_particles.contactSlots(), m_owned);
        }
      }
      if (c.flags & kWallHistoryOverflow) {
        // No spare: most particles never touch a wall, and the few that touch several (a box's edges and corners)
        // are there from the start; growth is one more store-only pass.
        const int grown = std::max<int>(m_particles.wallSlots() + 1, int(c.neededWallHistory));
        if (grown > 32)
          return Status(StatusCode::kResourceExhausted, "a particle has " + std::to_string(c.neededWallHistory) +
                                                            " simultaneous wall contacts, above the 32-slot limit");
        m_particles.resizeSlots(Multiplicity::kWallSlots, grown);
      }
      resetConditions();
      launchForces(dt, time, ForceSet::kAll, true);
      c = readConditions();
    }
    return Status::ok();
  }

  Status integrateSecondHalf(double dt) override {
    resetConditions();
    m_exec.forEach(m_owned, kernels::IntegrateSecondHalf<R>{integrateArgs(dt)});
    return integrationChecks(dt);
  }
  Status integrateBothHalves(double dt, double& moved2) override {
    resetConditions();
    moved2 = m_exec.maxOf(m_owned, kernels::IntegrateBothHalves<R>{integrateArgs(dt)});
    return integrationChecks(dt);
  }

  ParticleSnapshot snapshot(std::int64_t step, double time, const std::vector<std::string>& fields) const override {
    return m_rows.snapshot(step, time, m_owned, fields);
  }

  GeometrySnapshot geometry() const override {
    GeometrySnapshot g;
    g.vertices.resize(3 * std::size_t(m_numTri));
    m_mem.copyToHost(g.vertices.data(), m_triVerts.data(), g.vertices.size() * sizeof(Vec3d));
    for (Index t = 0; t < 3 * m_numTri; ++t) g.triangles.push_back(t);
    g.triangleMesh = m_setup.triMesh;
    g.triangleSurface = m_setup.triSurface;
    g.triangleMaterial = m_setup.triMaterial;
    g.meshNames = m_setup.meshNames;
    for (const auto& p : m_setup.planes) {
      g.planePoints.push_back(p.point);
      g.planeNormals.push_back(p.normal);
      g.planeMaterial.push_back(p.material);
    }
    g.planeNames = m_setup.planeNames;
    g.planeSurface = m_setup.planeSurface;
    g.surfaceNames = m_setup.surfaceNames;
    return g;
  }

  ContactStats contactStats() const override;

  double mechanicalEnergy() const override {
    return m_exec.sumOf(m_owned, kernels::MechanicalEnergy<R>{kineticOf(), {m_particles.template ptr<Field::Position>(),
                                                                            m_particles.template ptr<Field::Mass>(),
                                                                            m_setup.gravity, m_setup.grid.lo}});
  }
  double kineticEnergy() const override { return m_exec.sumOf(m_owned, kineticOf()); }
  void recordWallLoads(bool on) override { m_recordLoads = on && m_anyWalls; }
  std::vector<double> wallLoads() const override {
    std::vector<double> out(6 * surfaceCount(), 0.0);
    if (m_anyWalls && !out.empty()) m_mem.copyToHost(out.data(), m_surfaceLoads.data(), out.size() * sizeof(double));
    return out;
  }
  std::size_t surfaceCount() const {
    std::size_t n = m_setup.surfaceNames.size();
    for (auto s : m_setup.triSurface) n = std::max<std::size_t>(n, std::size_t(s) + 1);
    for (auto s : m_setup.planeSurface) n = std::max<std::size_t>(n, std::size_t(s) + 1);
    return n;
  }
  double massPastPlane(const Vec3d& point, const Vec3d& normal) const override {
    return m_exec.sumOf(m_owned, kernels::MassPastPlane<R>{m_particles.template ptr<Field::Position>(), m_particles.template ptr<Field::Mass>(),
                                                           point, normal});
  }
  kernels::KineticEnergy<R> kineticOf() const {
    return {m_particles.template ptr<Field::Velocity>(), m_particles.template ptr<Field::AngularVelocity>(),
            m_particles.template ptr<Field::Mass>(), m_particles.template ptr<Field::Radius>()};
  }
  double elasticEnergy() const override;
  ParticleProbe fastestParticle() const override;

  std::vector<std::pair<Gid, Gid>> candidatePairs() const override {
    const HostRows rows = hostRows();
    std::vector<Gid> gid(m_n);
    m_mem.copyToHost(gid.data(), m_particles.template ptr<Field::Gid>(), gid.size() * sizeof(Gid));
    std::vector<std::pair<Gid, Gid>> pairs;
    for (Index i = 0; i < m_owned; ++i)
      for (std::uint32_t e = 0; e < rows.count[i]; ++e) pairs.emplace_back(gid[i], gid[rows.at(i, e)]);
    std::sort(pairs.begin(), pairs.end());
    return pairs;
  }
  void fence() const override { m_exec.synchronize(); }
  std::vector<std::string> launchReport() const override {
    if constexpr (requires(const Exec& e) { e.tuningReport(); }) return m_exec.tuningReport();
    else return {};
  }

 private:
  using Rows = LocalRows<Exec, ParticleData<R>>;
  Rows& rows() override { return m_rows; }
  const Rows& rows() const override { return m_rows; }
  void localRowsChanged() override { sizeLocalBuffers(); }
  void init();
  // Lays the candidate rows out from the counting pass's counts (RowSlices): each slice as wide as its longest row.
  // The rows' buffers grow to fit, with a sixteenth to spare (a bed's counts drift from one rebuild to the next),
  // and shrink when they hold more than twice that.
  Status layOutRows() {
    const Index slices = m_owned == 0 ? 0 : ((m_owned - 1) >> m_nbrShift) + 1;
    std::uint32_t* start = rowStarts(slices);
    const std::uint32_t* width = start;  // compressed rows: the counts, where the starts go (rowCounts)
    if (m_nbrShift > 0 && slices > 0) {
      if (m_nbrWidth.bytes() < slices * sizeof(std::uint32_t)) m_nbrWidth.resize(slices * sizeof(std::uint32_t));
      m_exec.forEach(slices, kernels::SliceWidths{m_nbrCount.as<std::uint32_t>(), m_owned, m_nbrShift, m_nbrWidth.as<std::uint32_t>()});
      width = m_nbrWidth.as<std::uint32_t>();
    }
    const std::uint64_t units = slices ? m_exec.exclusiveScan(width, start, slices) : 0;
    if (units > std::numeric_limits<std::uint32_t>::max())
      return Status(StatusCode::kResourceExhausted, "the candidate rows need " + std::to_string(units << m_nbrShift) +
                                                        " entries, more than the 2^32 their starts can address: run on more ranks");
    const std::uint32_t end = std::uint32_t(units);  // the last row's end (RowSlices::count at shift 0)
    m_mem.copyFromHost(start + slices, &end, sizeof end);
    m_nbrEntries = std::size_t(units) << m_nbrShift;
    m_nbrRows = m_owned;
    auto fit = [](Buffer& b, std::size_t bytes) {
      const std::size_t want = std::max<std::size_t>(1, bytes + bytes / 16);
      if (b.bytes() < bytes || b.bytes() > 2 * want) b.resize(want);
    };
    fit(m_nbr, m_nbrEntries * sizeof(Index));
    // Without tangential history there are no slots to resolve: one byte stands in for the rows.
    fit(m_nbrSlot, m_setup.model.tangential ? m_nbrEntries * sizeof(std::int8_t) : 0);
    return Status::ok();
  }
  // Candidate rows: compressed (one row a slice) unless PFLOW_ROW_SLICE_SHIFT asks for wider slices.
  RowSlices nbrLayout() const {
    return {m_nbrStart.as<std::uint32_t>(), m_nbrShift, m_nbrShift ? m_nbrCount.as<std::uint32_t>() : nullptr};
  }
  // The rows' starts, one a slice and the end of the last.
  std::uint32_t* rowStarts(Index slices) {
    const std::size_t bytes = (std::size_t(slices) + 1) * sizeof(std::uint32_t);
    if (m_nbrStart.bytes() < bytes) m_nbrStart.resize(bytes + bytes / 16);
    return m_nbrStart.as<std::uint32_t>();
  }
  // Where the counting pass writes each row's length: compressed rows need no counts of their own once laid out
  // (RowSlices::count), so their counts go where their starts will be, and layOutRows scans them in place.
  std::uint32_t* rowCounts() {
    if (m_nbrShift == 0) return rowStarts(m_owned);
    const std::size_t bytes = std::max<std::size_t>(1, m_owned) * sizeof(std::uint32_t);
    if (m_nbrCount.bytes() < bytes) m_nbrCount.resize(bytes + bytes / 16);
    return m_nbrCount.as<std::uint32_t>();
  }
  // Host copies of the candidate rows (diagnostics and tests; never on the step path).
  struct HostRows {
    std::vector<Index> nbr;
    std::vector<std::uint32_t> count, start;
    std::uint32_t shift = 0;
    Index at(Index i, std::uint32_t e) const { return nbr[RowSlices{start.data(), shift}.at(i, e)]; }
  };
  // Rows not laid out for the owned particles of now (before the first rebuild, or between a migration and the
  // rebuild after it) read as empty.
  HostRows hostRows() const {
    HostRows h;
    h.shift = m_nbrShift;
    h.count.assign(m_owned, 0);
    if (m_nbrRows != m_owned || m_owned == 0) return h;
    h.nbr.resize(m_nbrEntries);
    h.start.resize(((m_owned - 1) >> m_nbrShift) + 2);
    m_mem.copyToHost(h.nbr.data(), m_nbr.data(), h.nbr.size() * sizeof(Index));
    m_mem.copyToHost(h.start.data(), m_nbrStart.data(), h.start.size() * sizeof(std::uint32_t));
    if (m_nbrShift) m_mem.copyToHost(h.count.data(), m_nbrCount.data(), h.count.size() * sizeof(std::uint32_t));
    else
      for (Index i = 0; i < m_owned; ++i) h.count[i] = h.start[i + 1] - h.start[i];
    return halfPairs() ? bothWays(h) : h;
  }
  // The GPU's pairs once lists each pair in its lower index's row only: the diagnostics (energy, statistics, the
  // error path) read every particle's candidates, so the host copy lists each pair in both rows.
  HostRows bothWays(const HostRows& upper) const;  // EngineDiagnostics.h
  // Triangle candidates: rows of exact length (WallCandidates), none in a scene without triangles (planes are a
  // mask a particle). The starts: one a particle and the end of the last row, the counts scanned in place.
  std::uint32_t* wallCandStarts(Index rows) {
    const std::size_t bytes = (std::size_t(rows) + 1) * sizeof(std::uint32_t);
    if (m_wallCandStart.bytes() < bytes) m_wallCandStart.resize(bytes + bytes / 16);
    return m_wallCandStart.as<std::uint32_t>();
  }
  const std::uint32_t* wallCandStart() const { return m_numTri ? m_wallCandStart.as<std::uint32_t>() : nullptr; }
  // Host copies of the triangle candidates (diagnostics): rows not laid out for the owned particles of now read as
  // empty, as hostRows's.
  void hostWallCandidates(std::vector<Index>& cand, std::vector<std::uint32_t>& start) const {
    start.assign(std::size_t(m_owned) + 1, 0);
    cand.clear();
    if (!m_anyWalls || !m_numTri || m_wallCandRows != m_owned) return;
    cand.resize(m_wallCandEntries);
    m_mem.copyToHost(start.data(), m_wallCandStart.data(), start.size() * sizeof(std::uint32_t));
    m_mem.copyToHost(cand.data(), m_wallCand.data(), cand.size() * sizeof(Index));
  }
  Status layOutWallCandidates() {
    std::uint32_t* start = m_wallCandStart.as<std::uint32_t>();
    const std::uint64_t total = m_owned ? m_exec.exclusiveScan(start, start, m_owned) : 0;
    if (total > std::numeric_limits<std::uint32_t>::max())
      return Status(StatusCode::kResourceExhausted, "the triangle candidates need " + std::to_string(total) +
                                                        " entries, more than the 2^32 their starts can address: run on more ranks");
    const std::uint32_t end = std::uint32_t(total);
    m_mem.copyFromHost(start + m_owned, &end, sizeof end);
    m_wallCandEntries = std::size_t(total);
    m_wallCandRows = m_owned;
    const std::size_t want = std::max<std::size_t>(1, total + total / 16) * sizeof(Index);
    if (m_wallCand.bytes() < total * sizeof(Index) || m_wallCand.bytes() > 2 * want) m_wallCand.resize(want);
    return Status::ok();
  }

  // The pair kernel, then the wall kernel, over the particles of `set`: every owned one, or one part of
  // the list splitBoundary made (boundary rows first, then interior ones).
  // Adhesion and fixed materials have pair kernels of their own (kC, kF), so that scenes without them pay nothing.
  void launchForces(double dt, double time, ForceSet set, bool storeOnly) {
    const bool fixed = m_setup.fixedMaterials != 0;
    if (m_setup.model.cohesion) {
      if (fixed) launchForcesWith<true, true>(dt, time, set, storeOnly);
      else launchForcesWith<true, false>(dt, time, set, storeOnly);
    } else {
      if (fixed) launchForcesWith<false, true>(dt, time, set, storeOnly);
      else launchForcesWith<false, false>(dt, time, set, storeOnly);
    }
  }
  template <bool kC, bool kF>
  void launchForcesWith(double dt, double time, ForceSet set, bool storeOnly) {
    const kernels::ForceArgs<R> args = forceArgs(dt, time, storeOnly);
    if (set == ForceSet::kAll || (m_numBoundary == 0 && set == ForceSet::kInterior)) {
      if (halfPairs()) {  // each pair once, by its lower index, the reactions by atomic adds
        kernels::ForceArgs<R> half = args;
        if constexpr (std::is_same_v<R, float>) {  // the sums as 16-byte rows: one vector atomic add a reaction
          if (m_sums.bytes() < std::size_t(m_owned) * 2 * sizeof(Sum4))
            m_sums.resize(std::size_t(m_owned) * 2 * sizeof(Sum4));
          half.sums = m_sums.as<Sum4>();
        }
        if (!storeOnly) m_exec.forEach(m_owned, kernels::ZeroSums<R>{args.force, args.torque, half.sums});
        m_exec.forEach(m_owned, kernels::ComputeForces<R, kC, kF, true, true>{half});
        if (half.sums && !storeOnly) m_exec.forEach(m_owned, kernels::FinishSums<R>{args.force, args.torque, half.sums});
        if (m_anyWalls) m_exec.forEach(m_owned, kernels::ComputeWallForces<R, kC>{args});
        return;
      }
      if constexpr (Exec::kPairsOnce) {
        if (m_numSlabs) {
          m_exec.forEachTwoColours(m_numSlabs, kernels::ComputePairsOnce<R, kC, kF>{{args}, m_slabStart.as<Index>(), m_slabItems.as<Index>(),
                                                                            m_owned1.as<std::uint32_t>(), m_numSlabs,
                                                                            m_setup.batchedContacts});
          if (m_anyWalls) m_exec.forEach(m_owned, kernels::ComputeWallForces<R, kC>{args});
          return;
        }
      }
      if (m_twoPhase) m_exec.forEach(m_owned, kernels::ComputeForces<R, kC, kF, true>{args});
      else m_exec.forEach(m_owned, kernels::ComputeForces<R, kC, kF>{args});
      if (m_anyWalls) m_exec.forEach(m_owned, kernels::ComputeWallForces<R, kC>{args});
      return;
    }
    const Index* list = m_split.as<Index>() + (set == ForceSet::kBoundary ? 0 : m_numBoundary);
    const Index count = set == ForceSet::kBoundary ? m_numBoundary : m_owned - m_numBoundary;
    if (m_twoPhase) m_exec.forEach(count, kernels::OverList<kernels::ComputeForces<R, kC, kF, true>>{{args}, list});
    else m_exec.forEach(count, kernels::OverList<kernels::ComputeForces<R, kC, kF>>{{args}, list});
    if (m_anyWalls) m_exec.forEach(count, kernels::OverList<kernels::ComputeWallForces<R, kC>>{{args}, list});
  }
  // After the candidate lists, where each pair is evaluated once (EngineSetup::pairsOnce): the particles by
  // slab, one cell layer thick along the slower of y and z with more layers (x when both have fewer than 4:
  // a slab's particles are then runs of one cell, poor for the caches), ascending within each slab.
  Status buildSlabs();  // EnginePairsOnce.h
  // After the candidate lists: which owned particles have a ghost candidate (their forces wait for the
  // halo), as one list with those first. Without ghosts nothing is boundary.
  void splitBoundary() {
    m_numBoundary = 0;
    if (m_n == m_owned || m_owned == 0) return;
    const std::size_t n = m_owned;
    if (m_split.bytes() < n * sizeof(Index)) m_split.resize(n * sizeof(Index) + n * sizeof(Index) / 4);
    if (m_splitFlag.bytes() < 2 * n * sizeof(std::uint32_t)) m_splitFlag.resize(2 * n * sizeof(std::uint32_t) + n * sizeof(std::uint32_t) / 2);
    std::uint32_t* flag = m_splitFlag.as<std::uint32_t>();
    std::uint32_t* scan = flag + n;
    m_exec.forEach(m_owned, kernels::MarkBoundary{m_nbr.as<Index>(), nbrLayout(), m_owned, flag});
    m_numBoundary = Index(m_exec.exclusiveScan(flag, scan, m_owned));
    m_exec.forEach(m_owned, kernels::SplitByFlag{flag, scan, m_numBoundary, m_split.as<Index>()});
  }
  // Per-particle work buffers sized for the current counts (kept when big enough).
  void sizeLocalBuffers() {
    auto atLeast = [](Buffer& b, std::size_t bytes) {
      if (b.bytes() < bytes) b.resize(bytes + bytes / 4);
    };
    const std::size_t n = std::max<Index>(1, m_n);
    atLeast(m_moved, movedBytes(n));
    atLeast(m_planeMask, n * sizeof(std::uint32_t));
  }
  void binTriangles();
  void resetConditions() { m_exec.forEach(1, kernels::ResetConditions{m_cond.as<Conditions>()}); }
  Conditions readConditions() const {
    Conditions c;
    m_mem.copyToHost(&c, m_cond.data(), sizeof c);
    return c;
  }
  // The second half kick's checks (IntegrateSecondHalf, IntegrateBothHalves): its flags read, an error for them.
  Status integrationChecks(double dt) const {
    const Conditions c = readConditions();
    if (c.flags & kNonFinite) return nonFiniteError(c.badParticle, dt);
    if (c.flags & kLeftDomain) return leftDomainError(c.outsideParticle, dt);
    return Status::ok();
  }
  Status nonFiniteError(Index i, double dt) const;
  Status deepOverlapError(Index i, double dt) const;
  Status tunnelError(Index i, double dt) const;
  Status leftDomainError(Index i, double dt) const;
  Status slotOverflowError(double dt) const;
  ParticleProbe probe(Index i) const;
  // Host copies of what the error diagnoses read (error path and start only).
  struct HostView {
    std::vector<Vec3d> pos;
    std::vector<R> rad, mass;
    std::vector<std::int32_t> mat;
    std::vector<Gid> gid;
    HostRows rows;
    std::vector<Index> wallCand;
    std::vector<std::uint32_t> wallCandStart;  // owned + 1 entries (all zero without triangles)
    std::vector<Vec3d> triVerts;
  };
  HostView hostView() const;
  // A particle's deepest contact: the partner (a particle's gid, or a wall's name) and the overlap [m].
  struct Deepest {
    std::string partner;
    Gid partnerGid = kNoGid;
    double overlap = -1, ratio = 0;
  };
  Deepest deepestContact(const HostView& h, Index i) const;
  std::string suggestion(double dt, const ParticleProbe& p) const {
    return dtSuggestion(dt > 0 ? dt : m_setup.dt, p);  // the forces at the start are computed with dt = 0
  }

  kernels::IntegrateArgs<R> integrateArgs(double dt) {
    kernels::IntegrateArgs<R> a{m_particles.template ptr<Field::Position>(), m_particles.template ptr<Field::Velocity>(),
            m_particles.template ptr<Field::AngularVelocity>(), m_particles.template ptr<Field::Force>(),
            m_particles.template ptr<Field::Torque>(), m_particles.template ptr<Field::Radius>(), m_particles.template ptr<Field::Mass>(),
            m_moved.as<Vec3f>(), m_setup.gravity, dt, m_cond.as<Conditions>(), m_setup.model.planarAxis};
    a.checkDomain = m_setup.checkDomain;
    a.domainLo = m_setup.domainLo;
    a.domainHi = m_setup.domainHi;
    a.material = m_particles.template ptr<Field::Material>();
    a.fixedMask = m_setup.fixedMaterials;
    return a;
  }
  kernels::ForceArgs<R> forceArgs(double dt, double time, bool storeOnly) {
    kernels::ForceArgs<R> a{};
    a.pos = m_particles.template ptr<Field::Position>();
    a.vel = m_particles.template ptr<Field::Velocity>();
    a.omega = m_particles.template ptr<Field::AngularVelocity>();
    a.radius = m_particles.template ptr<Field::Radius>();
    a.mass = m_particles.template ptr<Field::Mass>();
    a.material = m_particles.template ptr<Field::Material>();
    a.gid = m_particles.template ptr<Field::Gid>();
    a.force = m_particles.template ptr<Field::Force>();
    a.torque = m_particles.template ptr<Field::Torque>();
    a.nbr = m_nbr.as<Index>();
    a.nbrSlot = m_nbrSlot.as<std::int8_t>();
    a.nbrLayout = nbrLayout();
    a.slots = m_particles.contactSlots();
    a.histPartner = m_particles.template ptr<Field::HistoryPartner>();
    a.histDisp = m_particles.template ptr<Field::HistoryDisp>();
    a.histLayout = m_particles.layout(Multiplicity::kContactSlots);
    if (m_pool.active()) a.pool = m_pool.view();
    a.pooled = m_particles.template ptr<Field::HistoryPooled>();
    a.maxContacts = m_setup.maxContacts;
    a.planes = m_planes.as<PlaneParams>();
    a.planeMask = m_planeMask.as<std::uint32_t>();
    a.triVerts = m_triVerts.as<Vec3d>();
    a.triMesh = m_triMesh.as<std::int32_t>();
    a.triMaterial = m_triMaterial.as<std::int32_t>();
    a.triSurface = m_setup.triSurface.empty() ? nullptr : m_triSurface.as<std::int32_t>();
    a.planeSurface = m_setup.planeSurface.empty() ? nullptr : m_planeSurface.as<std::int32_t>();
    a.surfaceLoads = m_recordLoads ? m_surfaceLoads.as<double>() : nullptr;
    a.meshMotion = m_meshMotion.as<MeshMotionParams>();
    a.wallCand = m_wallCand.as<Index>();
    a.wallCandStart = wallCandStart();
    a.wallSlots = m_particles.wallSlots();
    a.wallKey = m_particles.template ptr<Field::WallKey>();
    a.wallDisp = m_particles.template ptr<Field::WallDisp>();
    a.wallLayout = m_particles.layout(Multiplicity::kWallSlots);
    a.params = m_params.as<ContactParams>();
    a.numMaterials = m_setup.numMaterials;
    a.dt = dt;
    a.time = time;
    a.maxOverlap = m_setup.maxOverlap;
    a.storeOnly = storeOnly;
    a.tangential = m_setup.model.tangential;
    a.rolling = m_setup.model.rolling;
    a.cond = m_cond.as<Conditions>();
    return a;
  }

  template <class T>
  void upload(Buffer& b, const std::vector<T>& v) {
    b.resize(std::max<std::size_t>(1, v.size()) * sizeof(T));
    m_mem.copyFromHost(b.data(), v.data(), v.size() * sizeof(T));
  }

  Exec m_exec;
  MemorySpace& m_mem;
  ParticleData<R> m_particles;
  LocalRows<Exec, ParticleData<R>> m_rows;  // reorder, pack, copy in, snapshot, ghosts: driven by the field table
  EngineSetup m_setup;
  Index& m_n = m_rows.n;          // local particles: the owned ones, then ghosts (distributed runs)
  Index& m_owned = m_rows.owned;
  Index m_numTri = 0;
  bool m_anyWalls = false;  // planes or triangles: the wall-force kernel runs
  bool m_binned = false;
  bool m_trianglesMoved = false;  // moveMeshes: some vertex is not where the last binning saw it
  std::uint32_t m_nbrShift = 0;                                  // RowSlices: 2^shift rows a slice (init)
  std::size_t m_nbrEntries = 0;                                  // the rows' entries, as laid out at the last rebuild
  Index m_nbrRows = kNoIndex;                                    // the owned particles they were laid out for
  std::size_t m_wallCandEntries = 0;  // triangle candidates, as laid out at the last rebuild
  Index m_wallCandRows = kNoIndex;    // the owned particles they were laid out for
  // The displacement since the last rebuild (float, 12 bytes a particle); during a cell sort, the keys and the
  // permutation (sortByCell).
  Buffer m_moved{m_mem, 0}, m_cellStart{m_mem, 0};
  static std::size_t permOffset(std::size_t n) { return (n * sizeof(std::uint32_t) + 255) / 256 * 256; }
  static std::size_t movedBytes(std::size_t n) { return std::max(n * sizeof(Vec3f), permOffset(n) + n * sizeof(Index)); }
  Buffer m_nbr{m_mem, 0}, m_nbrSlot{m_mem, 0}, m_nbrCount{m_mem, 0}, m_nbrStart{m_mem, 0}, m_nbrWidth{m_mem, 0};
  Buffer m_planes{m_mem, 0}, m_triRef{m_mem, 0}, m_triVerts{m_mem, 0}, m_triRebuild{m_mem, 0};
  Buffer m_triMesh{m_mem, 0}, m_triMaterial{m_mem, 0}, m_meshMotion{m_mem, 0};
  std::vector<bool> m_meshMoves;           // per mesh: has a motion, or a drive has set one
  Buffer m_movingTri{m_mem, 0};            // their triangles (moveMeshes)
  Index m_numMovingTri = 0;
  void listMovingTriangles() {
    std::vector<Index> t;
    for (Index k = 0; k < Index(m_setup.triMesh.size()); ++k)
      if (m_meshMoves[std::size_t(m_setup.triMesh[k])]) t.push_back(k);
    m_numMovingTri = Index(t.size());
    m_movingTri.resize(std::max<std::size_t>(1, t.size()) * sizeof(Index));
    if (!t.empty()) m_mem.copyFromHost(m_movingTri.data(), t.data(), t.size() * sizeof(Index));
  }
  Buffer m_triSurface{m_mem, 0}, m_planeSurface{m_mem, 0}, m_surfaceLoads{m_mem, 0};
  bool m_recordLoads = false;
  Buffer m_binStart{m_mem, 0}, m_binItems{m_mem, 0}, m_binCount{m_mem, 0};
  Buffer m_wallCand{m_mem, 0}, m_wallCandStart{m_mem, 0}, m_planeMask{m_mem, 0};
  Buffer m_params{m_mem, 0}, m_cond{m_mem, sizeof(Conditions)};
  Buffer m_split{m_mem, 0}, m_splitFlag{m_mem, 0};  // boundary rows, then interior ones (splitBoundary)
  // buildSlabs (pairs evaluated once): slab per particle, particles by slab, slab starts, owned candidates per row
  Buffer m_slabOf{m_mem, 0}, m_slabItems{m_mem, 0}, m_slabStart{m_mem, 0}, m_owned1{m_mem, 0};
  Index m_numSlabs = 0;  // 0: every particle evaluates all its pairs (ComputeForces)
  // The GPU's pairs once (EngineSetup::reproducible false; ComputeForces' kHalf): one process (MpiDomain::partition
  // keeps several ranks reproducible), no ghosts.
  bool m_halfPairs = false;
  Buffer m_sums{m_mem, 0};  // float pairs once: force and torque sums as 16-byte rows (Sum4)
  bool halfPairs() const { return m_halfPairs && m_n == m_owned; }
  Status pullHistoryToOwners();  // EnginePairsOnce.h
  kernels::HistoryRows<R> historyRows();  // EnginePairsOnce.h: the rows and slots the history moves see
  template <class Pass> Status untilSlotsSuffice(Pass pass);  // EnginePairsOnce.h
  bool m_twoPhase = false;  // ComputeForces' kTwoPhase: lockstep lanes or the GPU's layout (init); the same sums
  Index m_numBoundary = 0;
  HistoryPoolStore<Exec, R> m_pool;  // histories beyond the inline slots (HistoryPool.h)
  mutable typename HistoryPoolStore<Exec, R>::HostCopy m_savedPool;  // with save(): reduce_dt's in-memory checkpoint
  mutable std::vector<std::int32_t> m_savedPooled;
  void savePool() const, restorePool(), clearPooled(), mergePool(ParticleSnapshot& s) const;  // EnginePool.h
};

template <class Exec, class R>
void EngineImpl<Exec, R>::init() {
  const EngineSetup& s = m_setup;
  m_n = m_owned = Index(s.position.size());
  m_numTri = Index(s.triMesh.size());
  // The executor's slot layout, unless the setup asks for another executor's (tests), or PFLOW_SLOT_LAYOUT=
  // particle|slot overrides it (measurements). Candidate rows are compressed on both executors (slices of one
  // row); PFLOW_ROW_SLICE_SHIFT=k lays them out in slices of 2^k rows instead (measurements, tests).
  bool slotMajor = Exec::kSlotMajor;
  if (s.layout != EngineSetup::Layout::kExecutor) slotMajor = s.layout == EngineSetup::Layout::kGpu;
  if (const char* layout = std::getenv("PFLOW_SLOT_LAYOUT")) slotMajor = std::string(layout) == "slot";
  m_nbrShift = 0;
  if (const char* shift = std::getenv("PFLOW_ROW_SLICE_SHIFT")) m_nbrShift = std::uint32_t(std::clamp(std::atoi(shift), 0, 5));
  m_twoPhase = Exec::kLockstepLanes || s.layout == EngineSetup::Layout::kGpu;  // PFLOW_TWO_PHASE_PAIRS=0|1 overrides
  if (const char* two = std::getenv("PFLOW_TWO_PHASE_PAIRS")) m_twoPhase = std::atoi(two) != 0;
  // The GPU's pairs once: one process, pairs not summed in a canonical order (distributed runs sum theirs so).
  if (s.pairsOnce && m_twoPhase && !s.canonicalOrder) {
    m_halfPairs = !s.reproducible && !Exec::kPairsOnce;
    if (const char* half = std::getenv("PFLOW_GPU_HALF_PAIRS")) m_halfPairs = std::atoi(half) != 0;
  }
  m_pool.configure(s, Exec::kPairsOnce && !m_halfPairs, m_halfPairs);
  const int slots = m_pool.inlineSlots(s.historySlots);
  m_particles.allocate(m_n, slots, s.wallHistorySlots, slotMajor);
  m_pool.enableAt(slots, m_n);
  std::vector<Gid> gids(m_n);
  for (Index i = 0; i < m_n; ++i) gids[i] = s.gid.empty() ? Gid(i) : s.gid[i];
  // Host values (double) converted to the field's type at the run's precision; empty = zero.
  auto put = [&]<Field F, class T>(std::integral_constant<Field, F>, const std::vector<T>& src) {
    using Dst = typename ParticleData<R>::template Type<F>;
    std::vector<Dst> v(m_n);
    for (Index i = 0; i < m_n && !src.empty(); ++i) {
      if constexpr (std::is_same_v<T, Vec3d>) v[i] = vcast<typename FieldType<F, R>::Real>(src[i]);
      else v[i] = Dst(src[i]);
    }
    if (src.empty()) std::memset(static_cast<void*>(v.data()), 0, v.size() * sizeof(Dst));
    m_mem.copyFromHost(m_particles.buffer(F).data(), v.data(), v.size() * sizeof(Dst));
  };
  m_mem.copyFromHost(m_particles.buffer(Field::Position).data(), s.position.data(), s.position.size() * sizeof(Vec3d));
  const std::vector<Vec3d> none;
  put(std::integral_constant<Field, Field::Velocity>{}, s.velocity);
  put(std::integral_constant<Field, Field::AngularVelocity>{}, s.angularVelocity);
  put(std::integral_constant<Field, Field::Force>{}, none);
  put(std::integral_constant<Field, Field::Torque>{}, none);
  put(std::integral_constant<Field, Field::Radius>{}, s.radius);
  put(std::integral_constant<Field, Field::Mass>{}, s.mass);
  put(std::integral_constant<Field, Field::Material>{}, s.material);
  put(std::integral_constant<Field, Field::Gid>{}, gids);
  for (Field f : {Field::HistoryPartner, Field::WallKey})
    m_mem.fillBytes(m_particles.buffer(f).data(), 0xFF, m_particles.buffer(f).bytes());
  for (Field f : {Field::HistoryDisp, Field::WallDisp, Field::HistoryPooled})
    m_mem.fillBytes(m_particles.buffer(f).data(), 0, m_particles.buffer(f).bytes());

  m_moved.resize(movedBytes(m_n));
  m_cellStart.resize((std::size_t(s.grid.numCells()) + 1) * sizeof(Index));

  upload(m_planes, s.planes);
  upload(m_params, s.contactTable);
  upload(m_triRef, s.triVerts);
  upload(m_triVerts, s.triVerts);
  upload(m_triRebuild, s.triVerts);
  upload(m_triMesh, s.triMesh);
  upload(m_triMaterial, s.triMaterial);
  upload(m_triSurface, s.triSurface);
  upload(m_planeSurface, s.planeSurface);
  m_surfaceLoads.resize(std::max<std::size_t>(1, 6 * surfaceCount()) * sizeof(double));
  upload(m_meshMotion, s.meshMotion);
  for (const auto& m : s.meshMotion)
    m_meshMoves.push_back(m.angularSpeed != 0 || norm2(m.velocity) != 0 || (m.omega != 0 && norm2(m.vibration) != 0) || m.profilePoints > 0);
  listMovingTriangles();
  m_anyWalls = s.model.walls;  // deriveModel: off without planes and triangles (on in simulation.model: full)
  if (m_numTri) {  // the triangles' bins: a scene of planes alone needs none (8 bytes a cell)
    m_binStart.resize((std::size_t(s.grid.numCells()) + 1) * sizeof(Index));
    m_binCount.resize(std::size_t(s.grid.numCells()) * sizeof(std::uint32_t));
  }
  if (m_numTri) {  // no triangle candidates before the first rebuild
    std::uint32_t* start = wallCandStarts(m_n);
    m_mem.fillBytes(start, 0, m_wallCandStart.bytes());
  }
  m_planeMask.resize(std::max<std::size_t>(1, m_n) * sizeof(std::uint32_t));
  m_wallCand.resize(sizeof(Index));
}

template <class Exec, class R>
void EngineImpl<Exec, R>::binTriangles() {
  const CellGrid& g = m_setup.grid;
  const double margin = m_setup.maxRadius + m_setup.skin;
  const std::uint32_t nc = g.numCells();
  m_mem.fillBytes(m_binCount.data(), 0, m_binCount.bytes());
  m_exec.forEach(m_numTri, kernels::BinTriangles{g, m_triVerts.as<Vec3d>(), margin, m_binCount.as<std::uint32_t>(),
                                                 nullptr, nullptr, false});
  const std::uint64_t total = m_exec.exclusiveScan(m_binCount.as<std::uint32_t>(), m_binStart.as<Index>(), nc);
  const Index end = Index(total);
  m_mem.copyFromHost(m_binStart.as<Index>() + nc, &end, sizeof end);
  m_binItems.resize(std::max<std::uint64_t>(1, total) * sizeof(Index));
  m_mem.fillBytes(m_binCount.data(), 0, m_binCount.bytes());
  m_exec.forEach(m_numTri, kernels::BinTriangles{g, m_triVerts.as<Vec3d>(), margin, m_binCount.as<std::uint32_t>(),
                                                 m_binStart.as<Index>(), m_binItems.as<Index>(), true});
  m_exec.forEach(nc, kernels::SortBins{m_binStart.as<Index>(), m_binItems.as<Index>()});
}

}  // namespace pflow::compute

// The error path and diagnostics (host copies, never on the step path).
#include "compute/dem/EngineDiagnostics.h"
// The history pool's host side: checkpoints in memory and in files.
#include "compute/dem/EnginePool.h"
// Each pair once: the CPU's slabs, the GPU's histories moved to the pairs' owners.
#include "compute/dem/EnginePairsOnce.h"
