// A run split across MPI ranks, each owning the particles in its cells (issue 6; the seed patent's
// decomposition, FDPS's multi-section as the alternative). Host orchestration around the engine's
// device-side packing: every exchange is a count matrix (MPI_Alltoall) followed by non-blocking
// point-to-point messages between the ranks that have something to send.
//
// Ownership is by cell of the engine's grid: the decomposition assigns each cell to a rank, a particle
// belongs to the owner of its cell, and a rank's ghosts are the other ranks' particles in the 27 cells
// around its own (the cells are at least one contact range wide, so every candidate is among them).
// Contact forces come from full candidate lists, so ghosts are read-only: no force travels back.
#pragma once
#include <mpi.h>

#include <memory>
#include <string>
#include <vector>

#include "compute/decomp/Decomposition.h"
#include "compute/neighbor/CellGrid.h"
#include "compute/sim/Domain.h"
#include "compute/dem/Engine.h"
#include "compute/sim/RunConfig.h"

namespace pflow::compute {

struct MpiDomainOptions {
  DecompositionKind strategy = DecompositionKind::kSfc;  // the scene's simulation.decomposition
  // Rebalance on a rebuild when the busiest rank's smoothed cost exceeds the mean by this fraction.
  double tolerance = 0.05;
  bool rebalance = true;
  // Weight of the newest cost measurement in the smoothed cost per particle (1: no smoothing).
  double smoothing = 0.5;
  // What a rank's cost is: the measured seconds of its contact and force phases (the default), or its
  // particle count (deterministic: tests, and machines whose timings are noise, e.g. oversubscribed), each
  // particle counted by its engine's cost weight (DistributedRows::costWeights; SPH: fluid and wet walls more
  // than dry walls).
  enum class Cost { kMeasured, kCount } cost = Cost::kMeasured;
  // Candidates in global-id order (EngineSetup::canonicalOrder): the run equals one process bit for bit.
  // Off only to measure what it costs.
  bool canonicalOrder = true;
};

class MpiDomain final : public Domain {
 public:
  explicit MpiDomain(MPI_Comm comm, MpiDomainOptions options = {});

  int rank() const override { return m_rank; }
  int ranks() const override { return m_size; }
  Status partition(EngineSetup& setup) override;
  Status partitionPoints(const CellGrid& grid, const std::vector<Vec3d>& positions, std::vector<std::size_t>& mine,
                         const std::vector<double>& weights = {}) override;
  bool anyRebuild(bool local) override;
  Status migrate(DistributedRows& engine, double cost) override;
  Status exchangeGhosts(DistributedRows& engine) override;
  Status startRefresh(DistributedRows& engine) override;
  Status awaitRefresh() override;
  Status finishRefresh(DistributedRows& engine) override;
  Status agree(Status local) override;
  ParticleSnapshot gather(ParticleSnapshot local) override;
  void broadcast(ParticleSnapshot& s) override;
  void broadcast(std::vector<double>& values) override;
  double sum(double local) override;
  double max(double local) override;
  void sum(std::vector<double>& values) override;

  // Diagnostics and tests.
  const char* strategyName() const { return m_decomp ? m_decomp->name() : "none"; }
  int rebalances() const { return m_rebalances; }
  // Particles owned by each rank at the last rebuild.
  const std::vector<long long>& ownedPerRank() const { return m_ownedPerRank; }
  int ownerOfCell(std::uint32_t cell) const { return m_cellOwner[cell]; }
  // Particles this rank has sent to others at rebuilds, in all.
  long long migratedOut() const { return m_migratedOut; }
  // Where this rank's rebuilds spent their time [s], summed over rebuilds (host clock; the engine's device work
  // inside is synchronous): particles' cells (or positions) and weights copied to the host, the balance (rebalance included), the owner
  // of each particle, the migration (pack, messages, keep and append), the halo's rows and its first exchange.
  struct RebuildTimes {
    double positions = 0, weights = 0, balance = 0, owners = 0, migration = 0, haloRows = 0, ghosts = 0;
    int rebuilds = 0;
  };
  const RebuildTimes& rebuildTimes() const { return m_times; }

 private:
  // Builds the decomposition from per-particle weights `w` of this rank's particles at `pos` (cell
  // weights reduced over ranks for the curve, weighted samples gathered for the multi-section).
  Status decompose(const std::vector<Vec3d>& pos, const std::vector<double>& w);
  // Sends rows packed per destination (counts[d] rows for rank d, one packed block each, in rank order)
  // and receives the blocks every rank sends here (`recvCounts` rows per source, learnt through the count
  // matrix unless `countsKnown`), in rank order.
  std::vector<PackedRows> exchange(const std::vector<std::byte>& out, const std::vector<int>& counts, std::size_t rowBytes,
                                   std::vector<int>& recvCounts, bool countsKnown);
  // The two halves of exchange(): post() learns the counts (unless known) and starts the messages,
  // m_requests holds them until complete() waits for them (once) and returns the received blocks.
  void post(const std::vector<std::byte>& out, const std::vector<int>& counts, std::size_t rowBytes,
            std::vector<int>& recvCounts, bool countsKnown);
  std::vector<PackedRows> complete();
  // Rows to[d] for each rank d, concatenated, with the count per rank.
  static void flatten(const std::vector<std::vector<Index>>& to, std::vector<Index>& rows, std::vector<int>& counts);
  std::vector<Vec3d> positions(DistributedRows& engine) const;
  // Each owned particle's cell: the engine's (DistributedRows::cellKeys), else binned from its positions (then in
  // `pos` too).
  std::vector<std::uint32_t> cellsOf(DistributedRows& engine, std::vector<Vec3d>& pos) const;
  // The other ranks owning a cell among the 27 around cell c (count, then a pointer to them), cached.
  void haloRanksOf(std::uint32_t c, const std::int32_t*& dest, int& count);

  MPI_Comm m_comm;
  int m_rank = 0, m_size = 1;
  MpiDomainOptions m_options;
  CellGrid m_grid;
  std::unique_ptr<decomp::Decomposition> m_decomp;
  std::vector<std::int32_t> m_cellOwner;  // per cell of m_grid
  // Halo ranks per cell, filled as cells are met (haloRanksOf): m_haloAt[c] = -1 (not yet) or where cell
  // c's count and ranks start in m_haloRanks. Cleared by each decomposition.
  std::vector<std::int32_t> m_haloAt;
  std::vector<std::int32_t> m_haloRanks;
  double m_costPerUnit = 0;  // smoothed [s per unit of cost weight between rebuilds; per particle where all weigh 1]
  int m_rebalances = 0;
  long long m_migratedOut = 0;
  double m_lastImbalance = 1;
  std::vector<long long> m_ownedPerRank;
  // Halo, fixed between rebuilds: rows per destination rank (the rows themselves stay in the engine,
  // Engine::setHaloRows), counts both ways.
  std::vector<int> m_haloSend, m_haloRecv;
  std::vector<std::byte> m_out, m_in;
  std::vector<MPI_Request> m_requests;  // messages in flight (post .. complete)
  std::vector<PackedRows> m_blocks;     // where they land in m_in
  std::vector<PackedRows> m_arrived;    // awaitRefresh .. finishRefresh
  RebuildTimes m_times;
};

// The ranks of `comm` that share this process's node (MPI_Comm_split_type, shared memory): this process's index
// among them and their number. Collective over `comm`. A rank's GPU is its index modulo the node's devices.
struct NodeRanks {
  int rank = 0, size = 1;
};
NodeRanks nodeRanks(MPI_Comm comm);

}  // namespace pflow::compute
