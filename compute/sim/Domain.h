// How a run is split across processes. The step loop calls these hooks on every run: the base class is
// the single-process domain (every hook does nothing), compute/mpi's MpiDomain exchanges particles
// between MPI ranks (migration at rebuilds, ghosts every step) and keeps them balanced. The compute core
// itself never sees MPI.
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "common/Status.h"
#include "compute/particles/ParticleSnapshot.h"
#include "compute/sim/SimulationState.h"

namespace pflow::compute {

class DistributedRows;
struct CellGrid;
struct EngineSetup;

// Keeps the entries `mine` of v, in that order (a rank's share of the scene's per-particle arrays); an empty v
// (an optional array the scene left out) stays empty.
template <class T>
void keepRows(std::vector<T>& v, const std::vector<std::size_t>& mine) {
  if (v.empty()) return;
  std::vector<T> kept;
  kept.reserve(mine.size());
  for (std::size_t i : mine) kept.push_back(v[i]);
  v = std::move(kept);
}

class Domain {
 public:
  virtual ~Domain() = default;
  virtual int rank() const { return 0; }
  virtual int ranks() const { return 1; }
  // Every rank prepares the whole scene; this keeps this rank's share and gives each particle its
  // global id (its index in the scene).
  virtual Status partition(EngineSetup&) { return Status::ok(); }
  // The same for any solver: which of the scene's particles (at `positions`, binned by `grid`) this rank keeps;
  // `mine` gets their indices in the scene, ascending (their global ids). `weights`: each particle's expected share
  // of the work (empty: all alike), balanced across the ranks. One process: all of them.
  virtual Status partitionPoints(const CellGrid& grid, const std::vector<Vec3d>& positions, std::vector<std::size_t>& mine,
                                 const std::vector<double>& weights = {}) {
    (void)grid;
    (void)weights;
    mine.resize(positions.size());
    for (std::size_t i = 0; i < mine.size(); ++i) mine[i] = i;
    return Status::ok();
  }
  // True on every rank when any rank needs a neighbour rebuild (ranks rebuild together).
  virtual bool anyRebuild(bool local) { return local; }
  // Rebuild, before the sort: ghosts dropped, particles sent to the ranks that own their cells now (the
  // ranks rebalanced first when their cost differs by more than the tolerance). `cost`: seconds this rank
  // spent in contacts and forces since the last rebuild.
  virtual Status migrate(DistributedRows&, double /*cost*/) { return Status::ok(); }
  // Rebuild, after the sort: the ghosts (particles of other ranks within reach of this rank's cells).
  virtual Status exchangeGhosts(DistributedRows&) { return Status::ok(); }
  // Between rebuilds, after the first half step: the ghosts' positions and velocities, in three parts so
  // that the interior particles' forces are computed while the messages travel: startRefresh packs and
  // sends this rank's rows and posts the receives, awaitRefresh waits for the messages, finishRefresh
  // writes the ghosts.
  virtual Status startRefresh(DistributedRows&) { return Status::ok(); }
  virtual Status awaitRefresh() { return Status::ok(); }
  virtual Status finishRefresh(DistributedRows&) { return Status::ok(); }
  // The step's outcome, the same on every rank: OK, or the error of the lowest failing rank.
  virtual Status agree(Status local) { return local; }
  // All ranks' particles in one snapshot ordered by id, on rank 0 (an empty one elsewhere). Collective.
  virtual ParticleSnapshot gather(ParticleSnapshot local) { return local; }
  // Rank 0's snapshot, or values, to every rank (collective; one process: as they are).
  virtual void broadcast(ParticleSnapshot& /*s*/) {}
  virtual void broadcast(std::vector<double>& /*values*/) {}
  // Sum and maximum over ranks (collective).
  virtual double sum(double local) { return local; }
  virtual double max(double local) { return local; }
  // Element-wise sum over ranks, in place (collective).
  virtual void sum(std::vector<double>& /*values*/) {}
};

// A distributed resume (DEM's and SPH's resume()), collective: rank 0's state on every rank, its scalars into
// `scalars`, and this rank's share of its particles, split as a new run's scene is (partitionPoints), in `rows`.
// `weigh` (optional) gives each particle's balance weight from rank 0's particles and positions; this rank's share of
// them comes back in `weights`.
struct ResumeShare {
  ParticleSnapshot rows;
  std::vector<double> weights;
};
inline Result<ResumeShare> shareForResume(
    Domain& domain, const CellGrid& grid, const SimulationState& given, SimulationState& scalars,
    const std::function<std::vector<double>(const ParticleSnapshot&, const std::vector<Vec3d>&)>& weigh = {}) {
  std::vector<double> v = given.scalars();
  domain.broadcast(v);
  scalars.setScalars(v);
  ParticleSnapshot all = given.particles;
  domain.broadcast(all);
  const SnapshotArray* x = all.find("position");
  if (!x) return Status(StatusCode::kInvalidArgument, "the checkpoint's state has no position");
  const std::vector<Vec3d> pos(x->as<Vec3d>(), x->as<Vec3d>() + all.n);
  ResumeShare share;
  if (weigh) share.weights = weigh(all, pos);
  std::vector<std::size_t> mine;
  if (Status st = domain.partitionPoints(grid, pos, mine, share.weights); !st.isOk()) return st;
  keepRows(share.weights, mine);
  share.rows = keepSnapshotRows(all, mine);
  return share;
}

}  // namespace pflow::compute
