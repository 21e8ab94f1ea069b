#include "compute/decomp/Decomposition.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace pflow::compute::decomp {

namespace {

// Spreads the low 21 bits of v to every third bit.
std::uint64_t spread3(std::uint32_t v) {
  std::uint64_t x = v & 0x1fffffu;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

Status checkWeights(const std::vector<double>& w, const char* what) {
  for (std::size_t k = 0; k < w.size(); ++k)
    if (!(w[k] >= 0) || !std::isfinite(w[k]))
      return invalidArgument(std::string(what) + "[" + std::to_string(k) + "]: a weight must be finite and >= 0");
  return Status::ok();
}

// Splits items (already in order) into `parts` contiguous groups of about equal weight: the first index of
// each group. A boundary goes before or after the item that crosses k * total / parts, whichever is closer.
std::vector<std::size_t> splitContiguous(const std::vector<double>& w, int parts) {
  std::vector<std::size_t> first(std::size_t(parts), w.size());
  first[0] = 0;
  const double total = std::accumulate(w.begin(), w.end(), 0.0);
  double acc = 0;
  std::size_t k = 0;
  for (int p = 1; p < parts; ++p) {
    const double target = total * p / parts;
    while (k < w.size() && acc + w[k] <= target) acc += w[k++];
    // Item k crosses the target: take it too when that lands closer, keeping groups non-decreasing.
    if (k < w.size() && (acc + w[k]) - target < target - acc) acc += w[k++];
    first[std::size_t(p)] = std::max(k, first[std::size_t(p) - 1]);
  }
  return first;
}

// Cut positions splitting the (position, weight) pairs into `parts` groups of about equal weight: each cut
// halfway between the last sample of one group and the first of the next.
std::vector<double> cutsAlong(std::vector<std::pair<double, double>>& items, int parts) {
  std::sort(items.begin(), items.end());
  std::vector<double> w(items.size());
  for (std::size_t k = 0; k < items.size(); ++k) w[k] = items[k].second;
  const auto first = splitContiguous(w, parts);
  std::vector<double> cuts;
  for (int p = 1; p < parts; ++p) {
    const std::size_t f = first[std::size_t(p)];
    double cut;
    if (items.empty()) cut = 0;
    else if (f == 0) cut = items.front().first;
    else if (f >= items.size()) cut = items.back().first;
    else cut = 0.5 * (items[f - 1].first + items[f].first);
    cuts.push_back(cut);
  }
  for (std::size_t c = 1; c < cuts.size(); ++c) cuts[c] = std::max(cuts[c], cuts[c - 1]);
  return cuts;
}

int slabOf(const std::vector<double>& cuts, double x) {
  return int(std::upper_bound(cuts.begin(), cuts.end(), x) - cuts.begin());
}

}  // namespace

std::uint64_t mortonKey(std::uint32_t cx, std::uint32_t cy, std::uint32_t cz) {
  return spread3(cx) | spread3(cy) << 1 | spread3(cz) << 2;
}

double imbalance(const std::vector<double>& rankWeights) {
  if (rankWeights.empty()) return 0;
  const double total = std::accumulate(rankWeights.begin(), rankWeights.end(), 0.0);
  if (!(total > 0)) return 0;
  return *std::max_element(rankWeights.begin(), rankWeights.end()) / (total / double(rankWeights.size()));
}

std::array<int, 3> chooseDivisions(int ranks, Vec3d extent) {
  std::array<int, 3> best{ranks, 1, 1};
  double bestArea = std::numeric_limits<double>::infinity();
  const double ex = std::max(extent.x, 1e-300), ey = std::max(extent.y, 1e-300), ez = std::max(extent.z, 1e-300);
  for (int a = 1; a <= ranks; ++a) {
    if (ranks % a) continue;
    for (int b = 1; b <= ranks / a; ++b) {
      if ((ranks / a) % b) continue;
      const int c = ranks / a / b;
      // Total area of the cut planes: (a - 1) planes of ey * ez, and so on.
      const double area = (a - 1) * ey * ez + (b - 1) * ex * ez + (c - 1) * ex * ey;
      if (area < bestArea * (1 - 1e-12)) {
        bestArea = area;
        best = {a, b, c};
      }
    }
  }
  return best;
}

Result<SfcDecomposition> SfcDecomposition::build(const CellGrid& grid, const std::vector<double>& cellWeights,
                                                 int ranks) {
  if (ranks < 1) return invalidArgument("decomposition: ranks must be at least 1, got " + std::to_string(ranks));
  if (cellWeights.size() != grid.numCells())
    return invalidArgument("decomposition: " + std::to_string(cellWeights.size()) + " cell weights for " +
                           std::to_string(grid.numCells()) + " cells");
  if (grid.nx > (1 << 21) || grid.ny > (1 << 21) || grid.nz > (1 << 21))
    return invalidArgument("decomposition: the space-filling curve takes at most 2^21 cells per axis");
  if (Status s = checkWeights(cellWeights, "cell weight"); !s.isOk()) return s;

  // Cells in curve order.
  struct Cell {
    std::uint64_t key;
    double weight;
  };
  std::vector<Cell> cells;
  cells.reserve(cellWeights.size());
  for (int z = 0; z < grid.nz; ++z)
    for (int y = 0; y < grid.ny; ++y)
      for (int x = 0; x < grid.nx; ++x)
        cells.push_back({mortonKey(std::uint32_t(x), std::uint32_t(y), std::uint32_t(z)), cellWeights[grid.index(x, y, z)]});
  std::sort(cells.begin(), cells.end(), [](const Cell& a, const Cell& b) { return a.key < b.key; });
  std::vector<double> w(cells.size());
  for (std::size_t k = 0; k < cells.size(); ++k) w[k] = cells[k].weight;
  const auto first = splitContiguous(w, ranks);

  SfcDecomposition d;
  d.m_grid = grid;
  d.m_firstKey.resize(std::size_t(ranks));
  d.m_rankWeight.assign(std::size_t(ranks), 0.0);
  for (int r = 0; r < ranks; ++r) {
    const std::size_t f = first[std::size_t(r)];
    // An empty range starts where the next one does; rank 0 starts at key 0 so every cell has an owner.
    d.m_firstKey[std::size_t(r)] = r == 0 ? 0 : (f < cells.size() ? cells[f].key : std::numeric_limits<std::uint64_t>::max());
    const std::size_t end = r + 1 < ranks ? first[std::size_t(r) + 1] : cells.size();
    for (std::size_t k = f; k < end; ++k) d.m_rankWeight[std::size_t(r)] += w[k];
  }
  return d;
}

int SfcDecomposition::ownerOfCell(int cx, int cy, int cz) const {
  const std::uint64_t key = mortonKey(std::uint32_t(cx), std::uint32_t(cy), std::uint32_t(cz));
  // The last rank whose range starts at or before the key (empty ranges share a start with the next).
  return int(std::upper_bound(m_firstKey.begin(), m_firstKey.end(), key) - m_firstKey.begin()) - 1;
}

int SfcDecomposition::ownerOf(Vec3d x) const {
  int cx, cy, cz;
  m_grid.coords(x, cx, cy, cz);
  return ownerOfCell(cx, cy, cz);
}

Result<MultiSectionDecomposition> MultiSectionDecomposition::build(const std::vector<Vec3d>& samples,
                                                                   const std::vector<double>& weights, int ranks,
                                                                   Vec3d domainLo, Vec3d domainHi) {
  if (ranks < 1) return invalidArgument("decomposition: ranks must be at least 1, got " + std::to_string(ranks));
  if (!weights.empty() && weights.size() != samples.size())
    return invalidArgument("decomposition: " + std::to_string(weights.size()) + " weights for " +
                           std::to_string(samples.size()) + " samples");
  if (Status s = checkWeights(weights, "sample weight"); !s.isOk()) return s;
  for (std::size_t k = 0; k < samples.size(); ++k)
    if (!isFinite(samples[k]))
      return invalidArgument("decomposition: sample " + std::to_string(k) + " has a non-finite position");

  MultiSectionDecomposition d;
  d.m_div = chooseDivisions(ranks, domainHi - domainLo);
  const auto [nx, ny, nz] = d.m_div;
  auto weightOf = [&](std::size_t k) { return weights.empty() ? 1.0 : weights[k]; };

  // x: slabs.
  std::vector<std::pair<double, double>> items(samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) items[k] = {samples[k].x, weightOf(k)};
  d.m_xCuts = cutsAlong(items, nx);
  std::vector<std::vector<std::size_t>> inSlab(static_cast<std::size_t>(nx));
  for (std::size_t k = 0; k < samples.size(); ++k) inSlab[std::size_t(slabOf(d.m_xCuts, samples[k].x))].push_back(k);
  // y within each slab, then z within each column.
  d.m_yCuts.resize(std::size_t(nx));
  d.m_zCuts.assign(std::size_t(nx), std::vector<std::vector<double>>(std::size_t(ny)));
  for (int i = 0; i < nx; ++i) {
    const auto& slab = inSlab[std::size_t(i)];
    items.resize(slab.size());
    for (std::size_t m = 0; m < slab.size(); ++m) items[m] = {samples[slab[m]].y, weightOf(slab[m])};
    d.m_yCuts[std::size_t(i)] = cutsAlong(items, ny);
    std::vector<std::vector<std::size_t>> inColumn(static_cast<std::size_t>(ny));
    for (std::size_t k : slab) inColumn[std::size_t(slabOf(d.m_yCuts[std::size_t(i)], samples[k].y))].push_back(k);
    for (int j = 0; j < ny; ++j) {
      const auto& column = inColumn[std::size_t(j)];
      items.resize(column.size());
      for (std::size_t m = 0; m < column.size(); ++m) items[m] = {samples[column[m]].z, weightOf(column[m])};
      d.m_zCuts[std::size_t(i)][std::size_t(j)] = cutsAlong(items, nz);
    }
  }
  d.m_rankWeight.assign(std::size_t(ranks), 0.0);
  for (std::size_t k = 0; k < samples.size(); ++k) d.m_rankWeight[std::size_t(d.ownerOf(samples[k]))] += weightOf(k);
  return d;
}

int MultiSectionDecomposition::ownerOf(Vec3d x) const {
  const int i = slabOf(m_xCuts, x.x);
  const int j = slabOf(m_yCuts[std::size_t(i)], x.y);
  const int k = slabOf(m_zCuts[std::size_t(i)][std::size_t(j)], x.z);
  return (i * m_div[1] + j) * m_div[2] + k;
}

}  // namespace pflow::compute::decomp
