#include "compute/mpi/MpiDomain.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <string>

#include "common/Log.h"
#include "compute/dem/ParticleFields.h"
#include "compute/dem/Engine.h"

namespace pflow::compute {

namespace {
double secondsSince(std::chrono::steady_clock::time_point& mark) {
  const auto now = std::chrono::steady_clock::now();
  const double s = std::chrono::duration<double>(now - mark).count();
  mark = now;
  return s;
}
Vec3d cellCentre(const CellGrid& g, std::uint32_t c) {
  const std::uint32_t x = c % std::uint32_t(g.nx), y = (c / std::uint32_t(g.nx)) % std::uint32_t(g.ny),
                      z = c / (std::uint32_t(g.nx) * std::uint32_t(g.ny));
  return g.lo + g.cellSize * Vec3d{x + 0.5, y + 0.5, z + 0.5};
}
}  // namespace

MpiDomain::MpiDomain(MPI_Comm comm, MpiDomainOptions options) : m_comm(comm), m_options(options) {
  MPI_Comm_rank(m_comm, &m_rank);
  MPI_Comm_size(m_comm, &m_size);
}

// ---- decomposition ----------------------------------------------------------------------------

Status MpiDomain::decompose(const std::vector<Vec3d>& pos, const std::vector<double>& w) {
  const std::uint32_t cells = m_grid.numCells();
  m_haloAt.clear();  // every cell's halo ranks are worked out again
  m_haloRanks.clear();
  if (m_options.strategy == DecompositionKind::kSfc) {
    // The patent's: per-cell weights summed over ranks, contiguous ranges along the Morton curve.
    std::vector<double> weight(cells, 0.0);
    for (std::size_t i = 0; i < pos.size(); ++i) weight[m_grid.cellOf(pos[i])] += w[i];
    MPI_Allreduce(MPI_IN_PLACE, weight.data(), int(cells), MPI_DOUBLE, MPI_SUM, m_comm);
    auto d = decomp::SfcDecomposition::build(m_grid, weight, m_size);
    if (!d) return d.status();
    m_decomp = std::make_unique<decomp::SfcDecomposition>(std::move(d).value());
    auto* sfc = static_cast<decomp::SfcDecomposition*>(m_decomp.get());
    m_cellOwner.resize(cells);
    for (int z = 0; z < m_grid.nz; ++z)
      for (int y = 0; y < m_grid.ny; ++y)
        for (int x = 0; x < m_grid.nx; ++x) m_cellOwner[m_grid.index(x, y, z)] = sfc->ownerOfCell(x, y, z);
  } else {
    // FDPS's: cuts at weighted quantiles of a sample (at most ~2^16 points over all ranks).
    long long n = (long long)pos.size(), total = 0;
    MPI_Allreduce(&n, &total, 1, MPI_LONG_LONG, MPI_SUM, m_comm);
    const std::size_t every = std::max<long long>(1, total / 65536);
    std::vector<double> mine;  // x, y, z, w per sample
    for (std::size_t i = 0; i < pos.size(); i += every) mine.insert(mine.end(), {pos[i].x, pos[i].y, pos[i].z, w[i] * double(every)});
    int count = int(mine.size());
    std::vector<int> counts(m_size), displs(m_size, 0);
    MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, m_comm);
    for (int r = 1; r < m_size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    std::vector<double> all(std::size_t(displs.back() + counts.back()));
    MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, m_comm);
    std::vector<Vec3d> samples;
    std::vector<double> weights;
    for (std::size_t k = 0; k + 3 < all.size(); k += 4) {
      samples.push_back({all[k], all[k + 1], all[k + 2]});
      weights.push_back(all[k + 3]);
    }
    const Vec3d hi = m_grid.lo + m_grid.cellSize * Vec3d{double(m_grid.nx), double(m_grid.ny), double(m_grid.nz)};
    auto d = decomp::MultiSectionDecomposition::build(samples, weights, m_size, m_grid.lo, hi);
    if (!d) return d.status();
    m_decomp = std::make_unique<decomp::MultiSectionDecomposition>(std::move(d).value());
    m_cellOwner.resize(cells);
    for (std::uint32_t c = 0; c < cells; ++c) m_cellOwner[c] = m_decomp->ownerOf(cellCentre(m_grid, c));
  }
  return Status::ok();
}

Status MpiDomain::partitionPoints(const CellGrid& grid, const std::vector<Vec3d>& position, std::vector<std::size_t>& mine,
                                  const std::vector<double>& weights) {
  // Every rank holds the whole scene here, so the first decomposition needs no reduction of positions:
  // each rank weighs only the particles r, r + size, ... and the sum over ranks counts each once.
  m_grid = grid;
  const std::size_t n = position.size();
  std::vector<Vec3d> pos;
  std::vector<double> w;
  for (std::size_t i = std::size_t(m_rank); i < n; i += std::size_t(m_size)) {
    pos.push_back(position[i]);
    w.push_back(weights.empty() ? 1.0 : weights[i]);
  }
  if (Status st = decompose(pos, w); !st.isOk()) return st;
  mine.clear();
  for (std::size_t i = 0; i < n; ++i)
    if (m_cellOwner[m_grid.cellOf(position[i])] == m_rank) mine.push_back(i);
  m_ownedPerRank.assign(static_cast<std::size_t>(m_size), 0);
  long long owned = (long long)mine.size();
  MPI_Allgather(&owned, 1, MPI_LONG_LONG, m_ownedPerRank.data(), 1, MPI_LONG_LONG, m_comm);
  spdlog::debug("rank {}: {} of {} particles ({} decomposition)", m_rank, mine.size(), n, m_decomp->name());
  return Status::ok();
}

Status MpiDomain::partition(EngineSetup& s) {
  s.canonicalOrder = m_options.canonicalOrder;  // forces independent of the rows' order: one process's bits
  if (m_size > 1) s.inlineHistorySlots = 0;      // no history pool: migration carries the inline slots only
  if (m_size > 1) s.reproducible = true;         // ghosts: each pair from both sides (simulation.reproducible)
  std::vector<std::size_t> mine;
  if (Status st = partitionPoints(s.grid, s.position, mine); !st.isOk()) return st;
  // Keep this rank's particles, with their scene index as global id.
  keepRows(s.position, mine);
  keepRows(s.velocity, mine);
  keepRows(s.angularVelocity, mine);
  keepRows(s.radius, mine);
  keepRows(s.mass, mine);
  keepRows(s.material, mine);
  s.gid.assign(mine.begin(), mine.end());
  return Status::ok();
}

// ---- the step's collectives --------------------------------------------------------------------

bool MpiDomain::anyRebuild(bool local) {
  int any = local ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &any, 1, MPI_INT, MPI_LOR, m_comm);
  return any != 0;
}

double MpiDomain::sum(double local) {
  MPI_Allreduce(MPI_IN_PLACE, &local, 1, MPI_DOUBLE, MPI_SUM, m_comm);
  return local;
}

void MpiDomain::sum(std::vector<double>& values) {
  if (!values.empty()) MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_DOUBLE, MPI_SUM, m_comm);
}

double MpiDomain::max(double local) {
  MPI_Allreduce(MPI_IN_PLACE, &local, 1, MPI_DOUBLE, MPI_MAX, m_comm);
  return local;
}

Status MpiDomain::agree(Status local) {
  int failing = local.isOk() ? INT_MAX : m_rank;
  MPI_Allreduce(MPI_IN_PLACE, &failing, 1, MPI_INT, MPI_MIN, m_comm);
  if (failing == INT_MAX) return Status::ok();
  // The lowest failing rank's error, with its rank named, on every rank.
  int code = int(local.code());
  std::string message = local.message();
  MPI_Bcast(&code, 1, MPI_INT, failing, m_comm);
  int length = int(message.size());
  MPI_Bcast(&length, 1, MPI_INT, failing, m_comm);
  message.resize(std::size_t(length));
  MPI_Bcast(message.data(), length, MPI_CHAR, failing, m_comm);
  return Status(StatusCode(code), "rank " + std::to_string(failing) + ": " + message);
}

// ---- particle exchange -------------------------------------------------------------------------

std::vector<std::uint32_t> MpiDomain::cellsOf(DistributedRows& engine, std::vector<Vec3d>& pos) const {
  std::vector<std::uint32_t> cells;
  if (engine.cellKeys(m_grid, cells)) return cells;
  pos = positions(engine);
  cells.resize(pos.size());
  for (std::size_t i = 0; i < pos.size(); ++i) cells[i] = m_grid.cellOf(pos[i]);
  return cells;
}

std::vector<Vec3d> MpiDomain::positions(DistributedRows& engine) const {
  const ParticleSnapshot s = engine.snapshot(0, 0, {"position"});
  const SnapshotArray* a = s.find("position");
  return std::vector<Vec3d>(a->as<Vec3d>(), a->as<Vec3d>() + s.n);
}

void MpiDomain::flatten(const std::vector<std::vector<Index>>& to, std::vector<Index>& rows, std::vector<int>& counts) {
  rows.clear();
  counts.assign(to.size(), 0);
  for (std::size_t r = 0; r < to.size(); ++r) {
    counts[r] = int(to[r].size());
    rows.insert(rows.end(), to[r].begin(), to[r].end());
  }
}

std::vector<PackedRows> MpiDomain::exchange(const std::vector<std::byte>& out, const std::vector<int>& counts,
                                            std::size_t rowBytes, std::vector<int>& recvCounts, bool countsKnown) {
  post(out, counts, rowBytes, recvCounts, countsKnown);
  return complete();
}

void MpiDomain::post(const std::vector<std::byte>& out, const std::vector<int>& counts, std::size_t rowBytes,
                     std::vector<int>& recvCounts, bool countsKnown) {
  // The count matrix: each rank learns how many rows every other rank sends it.
  if (!countsKnown) {
    recvCounts.assign(static_cast<std::size_t>(m_size), 0);
    MPI_Alltoall(counts.data(), 1, MPI_INT, recvCounts.data(), 1, MPI_INT, m_comm);
  }
  std::size_t inRows = 0;
  for (int c : recvCounts) inRows += std::size_t(c);
  m_in.resize(inRows * rowBytes);
  m_requests.clear();
  m_blocks.clear();
  std::size_t at = 0;
  for (int r = 0; r < m_size; ++r) {
    const std::size_t bytes = std::size_t(recvCounts[r]) * rowBytes;
    if (bytes) {
      if (bytes > std::size_t(INT_MAX)) throw std::runtime_error("a halo or migration message above 2 GiB");
      m_blocks.push_back({m_in.data() + at, Index(recvCounts[r])});
      m_requests.emplace_back();
      MPI_Irecv(m_in.data() + at, int(bytes), MPI_BYTE, r, 0, m_comm, &m_requests.back());
    }
    at += bytes;
  }
  at = 0;
  for (int r = 0; r < m_size; ++r) {
    const std::size_t bytes = std::size_t(counts[r]) * rowBytes;
    if (bytes) {
      m_requests.emplace_back();
      MPI_Isend(out.data() + at, int(bytes), MPI_BYTE, r, 0, m_comm, &m_requests.back());
    }
    at += bytes;
  }
}

std::vector<PackedRows> MpiDomain::complete() {
  MPI_Waitall(int(m_requests.size()), m_requests.data(), MPI_STATUSES_IGNORE);
  m_requests.clear();
  return std::move(m_blocks);
}

Status MpiDomain::migrate(DistributedRows& engine, double cost) {
  engine.dropGhosts();
  if (m_size == 1) return Status::ok();  // one rank owns every cell
  // Rows travel in the engine's layout: every rank with the same slot counts.
  int slots[2] = {engine.historySlots(), engine.wallHistorySlots()};
  MPI_Allreduce(MPI_IN_PLACE, slots, 2, MPI_INT, MPI_MAX, m_comm);
  engine.ensureSlots(slots[0], slots[1]);

  auto mark = std::chrono::steady_clock::now();
  ++m_times.rebuilds;
  std::vector<Vec3d> pos;  // only where the engine gives no cells, or to rebalance
  std::vector<std::uint32_t> cells = cellsOf(engine, pos);
  const std::size_t n = cells.size();
  m_times.positions += secondsSince(mark);
  // Each particle's share of the rank's work (the engine's weights; all alike, and none built, when it gives none).
  std::vector<double> weight = engine.costWeights();
  const bool weighted = weight.size() == n;
  const double units = weighted ? std::accumulate(weight.begin(), weight.end(), 0.0) : double(n);
  m_times.weights += secondsSince(mark);

  // Cost per unit of weight (per particle where all weigh 1), smoothed over rebuilds; rebalance when the busiest
  // rank is above tolerance.
  if (m_options.cost == MpiDomainOptions::Cost::kCount) cost = units;
  const double measured = units > 0 ? cost / units : 0.0;
  m_costPerUnit = m_costPerUnit > 0 ? m_options.smoothing * measured + (1 - m_options.smoothing) * m_costPerUnit
                                            : measured;
  std::vector<double> rankCost(static_cast<std::size_t>(m_size));
  const double mine = m_costPerUnit * units;
  MPI_Allgather(&mine, 1, MPI_DOUBLE, rankCost.data(), 1, MPI_DOUBLE, m_comm);
  m_lastImbalance = decomp::imbalance(rankCost);
  if (m_options.rebalance && m_lastImbalance > 1 + m_options.tolerance) {
    // Every rank's particles weighted by its measured cost per unit of weight (a rank with no cost yet by the
    // mean) times their own weight, so dense, contact-rich regions count for more than loose ones.
    double total = 0;
    MPI_Allreduce(&units, &total, 1, MPI_DOUBLE, MPI_SUM, m_comm);
    const double sumCost = std::accumulate(rankCost.begin(), rankCost.end(), 0.0);
    const double meanPerUnit = total > 0 ? sumCost / total : 0.0;
    const double w = m_costPerUnit > 0 ? m_costPerUnit : (meanPerUnit > 0 ? meanPerUnit : 1.0);
    if (!weighted) weight.assign(n, 1.0);
    for (double& x : weight) x *= w;
    if (pos.size() != n) pos = positions(engine);
    if (Status s = decompose(pos, weight); !s.isOk()) return s;
    ++m_rebalances;
    spdlog::debug("rank {}: rebalanced ({:.3f} > 1 + {:.3f})", m_rank, m_lastImbalance, m_options.tolerance);
  }

  m_times.balance += secondsSince(mark);
  // Every particle to the owner of its cell now, however far it went since the last rebuild.
  std::vector<std::vector<Index>> leaving(static_cast<std::size_t>(m_size));
  std::vector<Index> stay;
  stay.reserve(n);
  for (Index i = 0; i < Index(n); ++i) {
    const int owner = m_cellOwner[cells[std::size_t(i)]];
    if (owner == m_rank) stay.push_back(i);
    else leaving[std::size_t(owner)].push_back(i);
  }
  m_times.owners += secondsSince(mark);
  std::vector<Index> rows;
  std::vector<int> counts, recvCounts;
  flatten(leaving, rows, counts);
  engine.pack(rows, counts, kMigrate, m_out);
  m_migratedOut += (long long)rows.size();
  const std::vector<PackedRows> in = exchange(m_out, counts, engine.rowBytes(kMigrate), recvCounts, false);
  if (!rows.empty()) engine.keepOwned(stay);  // a compaction of every field: only when some left
  engine.appendOwned(in);
  long long owned = (long long)engine.size();
  m_ownedPerRank.assign(static_cast<std::size_t>(m_size), 0);
  MPI_Allgather(&owned, 1, MPI_LONG_LONG, m_ownedPerRank.data(), 1, MPI_LONG_LONG, m_comm);
  m_times.migration += secondsSince(mark);
  return Status::ok();
}

Status MpiDomain::exchangeGhosts(DistributedRows& engine) {
  if (m_size == 1) return Status::ok();
  // Each owned particle goes to every other rank that owns a cell within the grid's reach of its own. The set
  // depends on the cell only: worked out once per decomposition, when a cell is first met (most cells are
  // interior, with no other rank around them).
  auto mark = std::chrono::steady_clock::now();
  std::vector<Vec3d> pos;
  const std::vector<std::uint32_t> cells = cellsOf(engine, pos);
  m_times.positions += secondsSince(mark);
  std::vector<std::vector<Index>> to(static_cast<std::size_t>(m_size));
  std::uint32_t lastCell = ~0u;
  const std::int32_t* dest = nullptr;
  int destCount = 0;
  for (Index i = 0; i < Index(cells.size()); ++i) {
    const std::uint32_t c = cells[std::size_t(i)];
    if (c != lastCell) {
      haloRanksOf(c, dest, destCount);
      lastCell = c;
    }
    for (int k = 0; k < destCount; ++k) to[std::size_t(dest[k])].push_back(i);
  }
  std::vector<Index> rows;
  flatten(to, rows, m_haloSend);
  engine.setHaloRows(rows, m_haloSend);
  m_times.haloRows += secondsSince(mark);
  engine.packHalo(kGhost, m_out);
  engine.setGhosts(exchange(m_out, m_haloSend, engine.rowBytes(kGhost), m_haloRecv, false));
  m_times.ghosts += secondsSince(mark);
  return Status::ok();
}

void MpiDomain::haloRanksOf(std::uint32_t c, const std::int32_t*& dest, int& count) {
  if (m_haloAt.size() != m_cellOwner.size()) m_haloAt.assign(m_cellOwner.size(), -1);  // new decomposition
  if (m_haloAt[c] < 0) {
    const int cx = int(c % std::uint32_t(m_grid.nx)), cy = int((c / std::uint32_t(m_grid.nx)) % std::uint32_t(m_grid.ny)),
              cz = int(c / (std::uint32_t(m_grid.nx) * std::uint32_t(m_grid.ny)));
    m_haloAt[c] = std::int32_t(m_haloRanks.size());
    std::int32_t n = 0;
    m_haloRanks.push_back(0);  // the count, then the ranks
    m_grid.forNeighbourCells(cx, cy, cz, [&](std::uint32_t nc) {
      const std::int32_t o = m_cellOwner[nc];
      const auto first = m_haloRanks.end() - n;
      if (o != m_rank && std::find(first, m_haloRanks.end(), o) == m_haloRanks.end()) m_haloRanks.push_back(o), ++n;
    });
    m_haloRanks[std::size_t(m_haloAt[c])] = n;
  }
  const std::int32_t* at = m_haloRanks.data() + m_haloAt[c];
  count = at[0];
  dest = at + 1;
}

// The halo's rows and counts are fixed between rebuilds: no count matrix, just the messages. m_out and
// m_in stay untouched while they are in flight (nothing else exchanges until finishRefresh).
Status MpiDomain::startRefresh(DistributedRows& engine) {
  if (m_size == 1) return Status::ok();
  engine.packHalo(kRefresh, m_out);
  post(m_out, m_haloSend, engine.rowBytes(kRefresh), m_haloRecv, true);
  return Status::ok();
}

Status MpiDomain::awaitRefresh() {
  m_arrived = complete();
  return Status::ok();
}

Status MpiDomain::finishRefresh(DistributedRows& engine) {
  if (m_size == 1) return Status::ok();
  engine.refreshGhosts(m_arrived);
  m_arrived.clear();
  return Status::ok();
}

ParticleSnapshot MpiDomain::gather(ParticleSnapshot local) {
  // Every array gathered to rank 0 (ranks produce the same arrays in the same order), then ordered by id.
  int n = int(local.n);
  std::vector<int> counts(static_cast<std::size_t>(m_size));
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, m_comm);
  long long total = 0;
  for (int r = 0; r < m_size; ++r) total += counts[r];
  ParticleSnapshot all;
  all.step = local.step;
  all.time = local.time;
  all.n = m_rank == 0 ? std::size_t(total) : 0;
  std::vector<int> at(static_cast<std::size_t>(m_size), 0);  // in rows
  for (int r = 1; r < m_size; ++r) at[r] = at[r - 1] + counts[r - 1];
  for (SnapshotArray& a : local.arrays) {
    // Rows travel as one datatype of a row's bytes (counts and offsets in rows: no int overflow past 2 GiB of an
    // array); a row's bytes are the ranks' that hold rows (a rank with none may not know a slot field's width).
    unsigned long long row = local.n ? a.data.size() / local.n : 0;
    MPI_Allreduce(MPI_IN_PLACE, &row, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, m_comm);
    SnapshotArray g{a.name, a.type, a.components, a.unit, {}};
    if (m_rank == 0) g.data.resize(std::size_t(total) * std::size_t(row));
    if (row > 0) {
      MPI_Datatype rowType;
      MPI_Type_contiguous(int(row), MPI_BYTE, &rowType);
      MPI_Type_commit(&rowType);
      MPI_Gatherv(a.data.data(), n, rowType, g.data.data(), counts.data(), at.data(), rowType, 0, m_comm);
      MPI_Type_free(&rowType);
    }
    all.arrays.push_back(std::move(g));
  }
  if (m_rank != 0) return all;
  const SnapshotArray* ids = all.find("id");
  if (!ids) return all;
  std::vector<std::size_t> order(all.n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  const Gid* id = ids->as<Gid>();
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return id[a] < id[b]; });
  for (SnapshotArray& a : all.arrays) {
    const std::size_t row = all.n ? a.data.size() / all.n : 0;
    std::vector<std::byte> sorted(a.data.size());
    for (std::size_t k = 0; k < all.n; ++k) std::memcpy(sorted.data() + k * row, a.data.data() + order[k] * row, row);
    a.data = std::move(sorted);
  }
  return all;
}

void MpiDomain::broadcast(ParticleSnapshot& s) {
  // The shape first (rows, step, time, and per array its name, type, components and unit), then the data in messages
  // of at most 1 GiB.
  std::string shape;
  if (m_rank == 0) {
    shape = std::to_string(s.n) + "\n" + std::to_string(s.step) + "\n";
    char t[32];
    std::snprintf(t, sizeof t, "%a", s.time);
    shape += std::string(t) + "\n";
    for (const SnapshotArray& a : s.arrays)
      shape += a.name + "\n" + std::to_string(int(a.type)) + "\n" + std::to_string(a.components) + "\n" + a.unit + "\n";
  }
  long long length = (long long)shape.size();
  MPI_Bcast(&length, 1, MPI_LONG_LONG, 0, m_comm);
  shape.resize(std::size_t(length));
  MPI_Bcast(shape.data(), int(length), MPI_CHAR, 0, m_comm);
  if (m_rank != 0) {
    std::vector<std::string> lines;
    std::size_t at = 0;
    for (std::size_t nl; (nl = shape.find('\n', at)) != std::string::npos; at = nl + 1) lines.push_back(shape.substr(at, nl - at));
    s = ParticleSnapshot{};
    s.n = std::size_t(std::stoull(lines[0]));
    s.step = std::stoll(lines[1]);
    s.time = std::strtod(lines[2].c_str(), nullptr);
    for (std::size_t k = 3; k + 3 < lines.size(); k += 4) {  // name, type, components, unit (maybe empty)
      SnapshotArray a{lines[k], ScalarType(std::stoi(lines[k + 1])), std::stoi(lines[k + 2]), lines[k + 3], {}};
      a.data.resize(s.n * std::size_t(a.components) * scalarBytesOf(a.type));
      s.arrays.push_back(std::move(a));
    }
  }
  constexpr std::size_t kChunk = std::size_t(1) << 30;
  for (SnapshotArray& a : s.arrays)
    for (std::size_t at = 0; at < a.data.size(); at += kChunk)
      MPI_Bcast(a.data.data() + at, int(std::min(kChunk, a.data.size() - at)), MPI_BYTE, 0, m_comm);
}

void MpiDomain::broadcast(std::vector<double>& values) {
  long long n = (long long)values.size();
  MPI_Bcast(&n, 1, MPI_LONG_LONG, 0, m_comm);
  values.resize(std::size_t(n));
  if (n > 0) MPI_Bcast(values.data(), int(n), MPI_DOUBLE, 0, m_comm);
}

NodeRanks nodeRanks(MPI_Comm comm) {
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  NodeRanks r;
  MPI_Comm_rank(node, &r.rank);
  MPI_Comm_size(node, &r.size);
  MPI_Comm_free(&node);
  return r;
}

}  // namespace pflow::compute
