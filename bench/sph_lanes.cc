// pflow-sph-lanes: a model of how many of a warp's 32 lanes the SPH rates pass keeps busy (docs/sph.md,
// "Performance"), computed on the CPU from a scene's particles, so that the idle lanes Nsight Compute reports on the
// GPU (19 of 32 in the walk on SPHERIC) can be taken apart without one. The particles are sorted by cell as the
// engine sorts them; a warp is 32 consecutive sorted particles, one a lane, as the CUDA executor launches the pass.
// Each lane walks as sph::kernels::Interact's walk does (its 25 rows of cells around its own, rows and end cells
// pruned by walkGap with the half skin as margin; dry boundary particles skipped; boundary particles take fluid
// neighbours only), in pieces of 32 candidates: a test per candidate, then a pair per neighbour. The warp runs a
// row while any lane walks it, a piece while any lane has it and a piece's pair loop as often as its busiest lane:
//   warp cost = sum over rows, pieces of (T_test x longest piece + T_pair x most neighbours in the piece)
// and the lanes' useful work is the sum of their own tests and pairs. Their ratio is the model's "active lanes".
// It is printed as it is and for orders of the lanes that a change could give: without the dry particles in the
// launch, and with fluid and boundary particles in warps of their own. JSON, one line per spacing.
//   pflow-sph-lanes --spacing 0.006 [--advance s] [--pair-cost 6]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numeric>
#include <vector>

#include "compute/sph/SphKernels.h"
#include "compute/sph/SphSimulation.h"
#include "bench/SphSceneAt.h"

using namespace pflow;
using namespace pflow::compute;

namespace {

// One lane's walk: for each of its 25 rows (-1 where pruned or off the grid) its pieces' lengths and neighbours.
struct LaneWork {
  bool active = false;
  bool fluid = false;
  std::vector<std::vector<std::pair<int, int>>> rows;  // [25][piece] = (candidates, neighbours)
  double tests = 0, pairs = 0;
  double marked = 0;  // candidates within the support plus the skin: what a hit-mask pass loops over after a sort
};

struct Particles {
  CellGrid grid;
  std::vector<Vec3d> x;  // sorted by cell
  std::vector<bool> fluid;
  std::vector<Index> cellStart;
};

LaneWork walk(const Particles& p, Index a, double support, double margin, double skin) {
  LaneWork w;
  w.fluid = p.fluid[a];
  w.rows.assign(25, {});
  const CellGrid& g = p.grid;
  int cx, cy, cz;
  g.coords(p.x[a], cx, cy, cz);
  if (!w.fluid) {  // MarkWet: a boundary particle with no fluid in its 125 cells has no rates
    bool wet = false;
    g.forNeighbourCells(cx, cy, cz, [&](std::uint32_t c) {
      for (Index b = p.cellStart[c]; b < p.cellStart[c + 1] && !wet; ++b) wet = p.fluid[b];
    });
    if (!wet) return w;
  }
  w.active = true;
  const double cs = g.cellSize, cut2 = support * support, mark2 = (support + skin) * (support + skin);
  g.forNeighbourCells(cx, cy, cz, [&](std::uint32_t c) {
    for (Index b = p.cellStart[c]; b < p.cellStart[c + 1]; ++b)
      w.marked += b != a && (w.fluid || p.fluid[b]) && norm2(p.x[b] - p.x[a]) < mark2;
  });
  const Vec3d o{p.x[a].x - (g.lo.x + cx * cs), p.x[a].y - (g.lo.y + cy * cs), p.x[a].z - (g.lo.z + cz * cs)};
  using sph::kernels::walkGap;
  for (int z = cz - 2; z <= cz + 2; ++z) {
    if (z < 0 || z >= g.nz) continue;
    const double gz = walkGap(o.z, z - cz, cs, margin, z == 0, z == g.nz - 1);
    if (gz * gz >= cut2) continue;
    for (int y = cy - 2; y <= cy + 2; ++y) {
      if (y < 0 || y >= g.ny) continue;
      const double gy = walkGap(o.y, y - cy, cs, margin, y == 0, y == g.ny - 1);
      const double g2 = gz * gz + gy * gy;
      if (g2 >= cut2) continue;
      int x0 = std::max(cx - 2, 0), x1 = std::min(cx + 2, g.nx - 1);
      while (x0 < cx) {
        const double gx = walkGap(o.x, x0 - cx, cs, margin, x0 == 0, false);
        if (g2 + gx * gx < cut2) break;
        ++x0;
      }
      while (x1 > cx) {
        const double gx = walkGap(o.x, x1 - cx, cs, margin, false, x1 == g.nx - 1);
        if (g2 + gx * gx < cut2) break;
        --x1;
      }
      auto& pieces = w.rows[(z - cz + 2) * 5 + (y - cy + 2)];
      const Index from = p.cellStart[g.index(x0, y, z)], end = p.cellStart[g.index(x1, y, z) + 1];
      for (Index piece = from; piece < end; piece += 32) {
        const int len = int(std::min<Index>(32, end - piece));
        int hits = 0;
        for (int j = 0; j < len; ++j) {
          const Index b = piece + Index(j);
          if (b == a || (!w.fluid && !p.fluid[b])) continue;
          hits += norm2(p.x[b] - p.x[a]) < cut2;
        }
        pieces.emplace_back(len, hits);
        w.tests += len;
        w.pairs += hits;
      }
    }
  }
  return w;
}

// The lanes in `order`, 32 a warp: their own tests and pairs, and what the warps execute for them (in units of a
// test): the tests of each piece as long as the warp's longest, the pair loops as long as the busiest lane's in
// each piece, and the pair loop if each lane ran its pairs in one loop over all its pieces (the least the pairs
// could cost a warp without moving work between lanes).
struct WarpCost {
  double tests = 0, pairs = 0;            // the lanes' own
  double warpTests = 0, warpPairs = 0;    // executed by the warps, as the walk runs
  double warpPairsOneLoop = 0;            // the pairs in one loop a lane
  double marked = 0, warpMarked = 0;      // a hit-mask pass: the marked candidates, in one loop a lane
};

WarpCost laneModel(const std::vector<LaneWork>& lanes, const std::vector<Index>& order) {
  WarpCost c;
  for (std::size_t w0 = 0; w0 < order.size(); w0 += 32) {
    const std::size_t w1 = std::min(order.size(), w0 + 32);
    for (int r = 0; r < 25; ++r) {
      std::size_t pieces = 0;
      for (std::size_t i = w0; i < w1; ++i) pieces = std::max(pieces, lanes[order[i]].rows[r].size());
      for (std::size_t k = 0; k < pieces; ++k) {
        int len = 0, hits = 0;
        for (std::size_t i = w0; i < w1; ++i) {
          const auto& row = lanes[order[i]].rows[r];
          if (k < row.size()) len = std::max(len, row[k].first), hits = std::max(hits, row[k].second);
        }
        c.warpTests += len;
        c.warpPairs += hits;
      }
    }
    double most = 0, mostMarked = 0;
    for (std::size_t i = w0; i < w1; ++i) {
      c.tests += lanes[order[i]].tests;
      c.pairs += lanes[order[i]].pairs;
      c.marked += lanes[order[i]].marked;
      most = std::max(most, lanes[order[i]].pairs);
      mostMarked = std::max(mostMarked, lanes[order[i]].marked);
    }
    c.warpPairsOneLoop += most;
    c.warpMarked += mostMarked;
  }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pflow-sph-lanes: a model of the SPH rates pass's busy lanes per warp"};
  std::string scene = "examples/dam_break_3d.yaml";
  std::vector<double> spacings = {0.02};
  double advance = 0;
  std::vector<double> pairCosts = {4, 6, 8};
  int threads = 0;
  app.add_option("--scene", scene, "an SPH scene file")->capture_default_str();
  app.add_option("--spacing", spacings, "particle spacings dp [m]")->delimiter(',');
  app.add_option("--advance", advance, "simulated seconds run first (CPU, float) to model the flow")->capture_default_str();
  app.add_option("--pair-cost", pairCosts, "instructions of a pair per instruction of a candidate test")->delimiter(',');
  app.add_option("--threads", threads, "OpenMP threads of the advance (0: all)");
  CLI11_PARSE(app, argc, argv);
  for (double dp : spacings) {
    auto loaded = bench::loadSphSceneAt(scene, dp);
    if (!loaded) {
      std::fprintf(stderr, "%s\n", loaded.status().message().c_str());
      return 1;
    }
    RunConfig cfg = loaded.value();
    cfg.sim.precision = Precision::kFloat;
    cfg.sim.threads = threads;
    auto setup = sph::prepareSphSetup(cfg);
    auto created = sph::SphSimulation::create(cfg);
    if (!setup || !created) {
      std::fprintf(stderr, "%s\n", (!setup ? setup.status() : created.status()).message().c_str());
      return 1;
    }
    auto& sim = *created.value();
    if (advance > 0)
      if (Status s = sim.runUntil(advance); !s.isOk()) {
        std::fprintf(stderr, "%s\n", s.message().c_str());
        return 3;
      }
    const ParticleSnapshot snap = sim.engine().stateArrays(sim.stepCount(), sim.time());
    const Vec3d* pos = snap.find("position")->as<Vec3d>();
    const std::int32_t* kind = snap.find("kind")->as<std::int32_t>();
    Particles p;
    p.grid = sim.grid();
    std::vector<Index> byCell(snap.n);
    std::iota(byCell.begin(), byCell.end(), Index(0));
    std::stable_sort(byCell.begin(), byCell.end(), [&](Index a, Index b) { return p.grid.cellOf(pos[a]) < p.grid.cellOf(pos[b]); });
    p.cellStart.assign(p.grid.numCells() + 1, 0);
    for (Index i : byCell) {
      p.x.push_back(pos[i]);
      p.fluid.push_back(kind[i] == sph::kernels::kFluid);
      ++p.cellStart[p.grid.cellOf(pos[i]) + 1];
    }
    std::partial_sum(p.cellStart.begin(), p.cellStart.end(), p.cellStart.begin());
    const double support = 2 * setup.value().h, margin = 0.5 * setup.value().skin * 1.001 + 1e-5 * p.grid.cellSize;
    const Index n = Index(p.x.size());
    std::vector<LaneWork> lanes(n);
#pragma omp parallel for schedule(dynamic, 4096)
    for (Index a = 0; a < n; ++a) lanes[a] = walk(p, a, support, margin, setup.value().skin);
    // The launch as it is; without the dry boundary particles; fluid and wet boundary particles apart (each in
    // sorted order).
    std::vector<Index> all(n), wet, split;
    std::iota(all.begin(), all.end(), Index(0));
    for (Index a = 0; a < n; ++a)
      if (lanes[a].active) wet.push_back(a);
    for (Index a : wet)
      if (lanes[a].fluid) split.push_back(a);
    for (Index a : wet)
      if (!lanes[a].fluid) split.push_back(a);
    double tests = 0, pairs = 0, fluidPairs = 0;
    std::size_t fluid = 0;
    for (const LaneWork& w : lanes) {
      tests += w.tests, pairs += w.pairs;
      if (w.fluid) fluidPairs += w.pairs, ++fluid;
    }
    nlohmann::json j{{"case", scene},
                     {"spacing", dp},
                     {"n", n},
                     {"fluid", fluid},
                     {"active", wet.size()},
                     {"advance_s", advance},
                     {"tests_per_particle", tests / n},
                     {"pairs_per_particle", pairs / n},
                     {"pairs_per_fluid_particle", fluid ? fluidPairs / fluid : 0.0}};
    for (const auto& [name, order] : {std::pair<const char*, const std::vector<Index>*>{"as_launched", &all}, {"without_dry", &wet},
                                      {"fluid_and_boundary_apart", &split}}) {
      const WarpCost w = laneModel(lanes, *order);
      nlohmann::json m{{"warp_tests_per_particle", w.warpTests / n},
                       {"warp_pairs_per_particle", w.warpPairs / n},
                       {"warp_pairs_one_loop_per_particle", w.warpPairsOneLoop / n},
                       {"marked_per_particle", w.marked / n},
                       {"warp_marked_one_loop_per_particle", w.warpMarked / n},
                       {"test_lanes", w.tests / w.warpTests},
                       {"pair_lanes", w.pairs / w.warpPairs}};
      for (double c : pairCosts) m["active_lanes_pair_cost_" + std::to_string(int(c))] = (w.tests + c * w.pairs) / (w.warpTests + c * w.warpPairs);
      j[name] = m;
    }
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
  }
  return 0;
}
