// What a distributed run (compute/mpi's MpiDomain, through the Domain hooks) needs of any solver's engine:
// its local rows (the owned particles, then ghosts: read-only copies of other ranks' particles) packed and
// unpacked by the field table's flags. The DEM Engine and the SPH SphEngine both are DistributedRows, so one
// MpiDomain migrates, balances and keeps the halo of either.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "compute/core/Types.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::compute {

struct CellGrid;

// `count` rows packed by DistributedRows::pack, as received from one rank.
struct PackedRows {
  const std::byte* data;
  Index count;
};

class DistributedRows {
 public:
  virtual ~DistributedRows() = default;
  virtual std::size_t size() const = 0;    // particles this engine owns (integrates, outputs)
  virtual std::size_t ghosts() const = 0;  // copies of other ranks' particles within reach
  // Explicit host copies of the named kSnapshot fields of the owned rows (MpiDomain reads "position").
  virtual ParticleSnapshot snapshot(std::int64_t step, double time, const std::vector<std::string>& fields) const = 0;
  // Per-particle slot fields (DEM's contact history): every rank of a run holds the same counts before rows travel.
  virtual int historySlots() const { return 0; }
  virtual int wallHistorySlots() const { return 0; }
  virtual void ensureSlots(int /*contactSlots*/, int /*wallSlots*/) {}
  // Each owned particle's share of the work, relative to the others' (the balance's weights: a rank's measured cost
  // is spread over its particles in these proportions). Empty: all alike (DEM).
  virtual std::vector<double> costWeights() { return {}; }
  // Each owned particle's cell of `grid` now, computed where the particles are (4 bytes a row to the host instead of
  // a 24-byte position). False: not offered (the caller bins the positions itself).
  virtual bool cellKeys(const CellGrid& /*grid*/, std::vector<std::uint32_t>& /*cells*/) { return false; }

  // Local rows are the owned particles [0, size()), then the ghosts [size(), size() + ghosts()). A rebuild is:
  // dropGhosts, keepOwned + appendOwned (migration), the engine's cell sort, setGhosts; between rebuilds
  // refreshGhosts. Packed rows are field by field (each a block of `count` values; slot-major slot fields slot by
  // slot), in this engine's layout: every rank of a run runs the same executor and precision.
  virtual std::size_t rowBytes(std::uint32_t fieldFlags) const = 0;
  // The fields carrying `fieldFlags` (kMigrate, kGhost, kRefresh) of local rows `rows`, packed on the device
  // as consecutive blocks of segments[0], segments[1], ... rows (one block per destination rank).
  virtual void pack(const std::vector<Index>& rows, const std::vector<int>& segments, std::uint32_t fieldFlags,
                    std::vector<std::byte>& out) const = 0;
  // The halo's rows, fixed from one rebuild to the next: kept on the device by setHaloRows (at the rebuild),
  // packed by packHalo (kGhost then, kRefresh every step) without uploading them again.
  virtual void setHaloRows(const std::vector<Index>& rows, const std::vector<int>& segments) = 0;
  virtual void packHalo(std::uint32_t fieldFlags, std::vector<std::byte>& out) const = 0;
  // The owned particles become rows `keep` (ascending or not), in that order; ghosts are dropped.
  virtual void keepOwned(const std::vector<Index>& keep) = 0;
  // Appends owned particles: blocks packed with kMigrate (every field that travels); ghosts are dropped.
  virtual void appendOwned(const std::vector<PackedRows>& blocks) = 0;
  // Replaces the ghosts by blocks packed with kGhost, in order, and bins them into cells.
  virtual void setGhosts(const std::vector<PackedRows>& blocks) = 0;
  // Overwrites the ghosts' kRefresh fields: blocks as in setGhosts, same rows.
  virtual void refreshGhosts(const std::vector<PackedRows>& blocks) = 0;
  virtual void dropGhosts() = 0;
};

}  // namespace pflow::compute
