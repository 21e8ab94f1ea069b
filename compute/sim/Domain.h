// How a run is split across processes. The step loop calls these hooks on every run: the base class is
// the single-process domain (every hook does nothing), compute/mpi's MpiDomain exchanges particles
// between MPI ranks (migration at rebuilds, ghosts every step) and keeps them balanced. The compute core
// itself never sees MPI.
#pragma once
#include <cstdint>
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

// A distributed resume (DEM's and SPH's resume()): rank 0's state on every rank (collective): its scalars into
// `scalars`, its particles returned; each rank then keeps its share (partitionPoints).
inline ParticleSnapshot shareState(Domain& domain, const SimulationState& given, SimulationState& scalars) {
  std::vector<double> v = given.scalars();
  domain.broadcast(v);
  scalars.setScalars(v);
  ParticleSnapshot all = given.particles;
  domain.broadcast(all);
  return all;
}

}  // namespace pflow::compute
