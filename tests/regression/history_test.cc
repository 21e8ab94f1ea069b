// Tangential history: keyed by the partner's gid, it survives reordering, grows without changing
// results when slots run out, and is forgotten when a contact ends.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <vector>

#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

constexpr double kR = 1e-3;

// Two spheres pressed together obliquely, sheared, both drifting fast through the cell grid so that
// their order in the arrays changes at rebuilds.
RunConfig shearedPair(double skin) {
  RunConfig c;
  c.materials = {material("m", 1e7, 0.3, 2500, 0.9, 0.5)};
  const double d = 2 * kR - 2e-6;
  const double th = -0.5;  // partner behind in y, ahead in x: their order flips as they cross y cells
  addParticle(c, {0, 0, 0}, kR, 0, {0, 3.0, 0}, {0, 0, 40});
  addParticle(c, {d * std::cos(th), d * std::sin(th), 0}, kR, 0, {-0.01, 3.0, 0.02}, {5, 0, 0});
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1;
  c.sim.dt = 2e-7;
  c.sim.skin = skin;
  c.sim.domain = compute::Aabb{{-0.01, -0.01, -0.01}, {0.01, 0.05, 0.01}};
  return c;
}

std::vector<Vec3d> trajectory(const RunConfig& c, int steps, std::int64_t* rebuilds, double* maxTangential,
                               int* swapped) {
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  std::vector<Vec3d> out;
  for (int k = 0; k < steps; ++k) {
    EXPECT_TRUE(sim.value()->step().isOk());
    const auto s = sim.value()->snapshot();
    const Vec3d* f = s.find("force")->as<Vec3d>();
    const Gid* id = s.find("id")->as<Gid>();
    const int first = id[0] == 0 ? 0 : 1;  // report by gid, not by array slot
    *swapped += first;
    out.push_back(f[first]);
    const Vec3d* x = s.find("position")->as<Vec3d>();
    const Vec3d n = (1.0 / norm(x[1] - x[0])) * (x[1] - x[0]);
    const Vec3d ft = f[first] - dot(f[first], n) * n;
    *maxTangential = std::max(*maxTangential, norm(ft));
  }
  *rebuilds = sim.value()->rebuilds();
  return out;
}

TEST(History, SurvivesReorderingAtRebuilds) {
  std::int64_t rebuildsA = 0, rebuildsB = 0;
  double ftA = 0, ftB = 0;
  int swappedA = 0, swappedB = 0;
  const auto a = trajectory(shearedPair(1e-6), 3000, &rebuildsA, &ftA, &swappedA);  // rebuilds every few steps
  const auto b = trajectory(shearedPair(5e-3), 3000, &rebuildsB, &ftB, &swappedB);  // never after the first
  EXPECT_GT(swappedA, 0);  // the pair really changed places in the arrays
  EXPECT_LT(swappedA, 3000);
  EXPECT_GT(rebuildsA, 100);
  EXPECT_EQ(rebuildsB, 1);
  EXPECT_GT(ftA, 1e-6);  // the tangential spring is really loaded
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_NEAR(a[k].x, b[k].x, 1e-12 * norm(b[k]) + 1e-18) << "step " << k;
    ASSERT_NEAR(a[k].y, b[k].y, 1e-12 * norm(b[k]) + 1e-18) << "step " << k;
    ASSERT_NEAR(a[k].z, b[k].z, 1e-12 * norm(b[k]) + 1e-18) << "step " << k;
  }
}

// A central sphere touching six neighbours, started with one history slot: the slots grow and the
// forces are exactly those of a run that had enough slots from the start.
TEST(History, SlotOverflowGrowsWithoutChangingResults) {
  auto cluster = [](int slots) {
    RunConfig c;
    c.materials = {material("m", 1e7, 0.3, 2500, 0.5, 0.5)};
    const double d = 2 * kR - 1e-6;
    addParticle(c, {0, 0, 0}, kR, 0, {0, 0, 0}, {10, 20, 30});
    const Vec3d dirs[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int k = 0; k < 6; ++k) addParticle(c, d * dirs[k], kR, 0, 0.01 * dirs[(k + 2) % 6], {0, 0, 0});
    c.sim.gravity = {0, 0, 0};
    c.sim.duration = 1;
    c.sim.historySlots = slots;
    return c;
  };
  auto small = Simulation::create(cluster(1));
  auto big = Simulation::create(cluster(16));
  ASSERT_TRUE(small.isOk() && big.isOk());
  EXPECT_GE(small.value()->engine().historySlots(), 6);
  for (int k = 0; k < 200; ++k) {
    ASSERT_TRUE(small.value()->step().isOk());
    ASSERT_TRUE(big.value()->step().isOk());
  }
  const auto a = small.value()->snapshot(), b = big.value()->snapshot();
  for (std::size_t i = 0; i < a.n; ++i) {
    EXPECT_EQ(a.find("force")->as<Vec3d>()[i].x, b.find("force")->as<Vec3d>()[i].x);
    EXPECT_EQ(a.find("angular_velocity")->as<Vec3d>()[i].z, b.find("angular_velocity")->as<Vec3d>()[i].z);
  }
  EXPECT_EQ(small.value()->contactStats().historyEntries, big.value()->contactStats().historyEntries);
}

// History exists while two spheres touch and is gone when they part.
TEST(History, ForgottenWhenContactEnds) {
  RunConfig c;
  c.materials = {material("m", 1e7, 0.3, 2500, 0.5, 0.5)};
  addParticle(c, {-kR - 1e-7, 0, 0}, kR, 0, {0.1, 0.05, 0});
  addParticle(c, {kR + 1e-7, 0, 0}, kR, 0, {-0.1, 0, 0});
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1;
  auto sim = Simulation::create(c);
  ASSERT_TRUE(sim.isOk());
  std::size_t during = 0;
  for (int k = 0; k < 2000; ++k) {
    ASSERT_TRUE(sim.value()->step().isOk());
    during = std::max(during, sim.value()->contactStats().historyEntries);
  }
  EXPECT_EQ(during, 2u);  // one slot on each side
  EXPECT_EQ(sim.value()->contactStats().particleContacts, 0u);
  EXPECT_EQ(sim.value()->contactStats().historyEntries, 0u);
}


namespace pairs_once {
RunConfig heap(int threads) { return test::pouredHeap(kR, threads); }
std::vector<Vec3d> run(int threads, bool once, int steps, std::size_t* history = nullptr, long* rebuilds = nullptr) {
  compute::SimulationOptions o;
  o.pairsOnce = once;
  auto sim = Simulation::create(heap(threads), o);
  EXPECT_TRUE(sim.isOk());
  if (!sim.isOk()) return {};
  EXPECT_TRUE(sim.value()->runSteps(steps).isOk());
  if (history) *history = sim.value()->contactStats().historyEntries;
  if (rebuilds) *rebuilds = sim.value()->rebuilds();
  const auto s = sim.value()->snapshot();
  std::vector<Vec3d> x(s.n);
  for (std::size_t k = 0; k < s.n; ++k) x[s.find("id")->as<Gid>()[k]] = s.find("position")->as<Vec3d>()[k];
  return x;
}
}  // namespace pairs_once

// Each pair evaluated once on the CPU (its owner adds the reaction to the partner, keeps the history and
// hands it over when a rebuild changes the owner) follows the evaluation from both sides to round-off over
// 3000 steps of pouring, with as many histories held; and its sums do not depend on the thread count.
TEST(History, PairsOnceMatchesBothSidesAndIgnoresThreadCount) {
  std::size_t hOnce = 0, hBoth = 0;
  long rebuilds = 0;
  const auto once = pairs_once::run(2, true, 3000, &hOnce, &rebuilds);
  const auto both = pairs_once::run(2, false, 3000, &hBoth);
  const auto onceOneThread = pairs_once::run(1, true, 3000);
  ASSERT_EQ(once.size(), 600u);
  ASSERT_EQ(both.size(), 600u);
  EXPECT_GT(rebuilds, 5);
  // Grains crossed cell layers, so pairs changed owner at rebuilds (a cell is 2.2 radii here): with
  // PullHistory made a no-op the positions differ by 0.12 mm and the bound below fails.
  const RunConfig start = pairs_once::heap(1);
  double moved = 0;
  for (std::size_t k = 0; k < once.size(); ++k) moved = std::max(moved, norm(once[k] - start.particles.position[k]));
  EXPECT_GT(moved, 3 * kR) << "largest displacement [m]";
  double worst = 0;
  for (std::size_t k = 0; k < once.size(); ++k) {
    worst = std::max(worst, norm(once[k] - both[k]));
    EXPECT_EQ(once[k].x, onceOneThread[k].x) << k;
    EXPECT_EQ(once[k].y, onceOneThread[k].y) << k;
    EXPECT_EQ(once[k].z, onceOneThread[k].z) << k;
  }
  // Measured 9e-12 m: round-off (each side's force is the other's negative only to the last bit) grown by
  // the pour's chaos. A wrong reaction or a lost history moves grains by micrometres.
  EXPECT_LT(worst, 1e-6 * kR) << "largest position difference [m]";
  EXPECT_EQ(hOnce, hBoth);
  EXPECT_GT(hBoth, 600u);  // a packed heap: histories really held
}

// The history pool (compute/dem/contact/HistoryPool.h): with two inline slots a particle and the rest pooled, a
// poured heap evaluated from both sides (the GPU's way) follows the run that keeps every history inline bit for
// bit, holds as many histories, grows the pool within steps (it starts at 256 entries), and a checkpoint taken with
// pooled histories (merged into the inline slots) resumes bit for bit.
namespace pool {
struct InlineSlots {  // PFLOW_INLINE_SLOTS for the simulations created in its scope
  explicit InlineSlots(const char* k) { setenv("PFLOW_INLINE_SLOTS", k, 1); }
  ~InlineSlots() { unsetenv("PFLOW_INLINE_SLOTS"); }
};
struct TwoPhase {  // PFLOW_TWO_PHASE_PAIRS for the simulations created in its scope (none: the executor's choice)
  explicit TwoPhase(const char* on) {
    if (on) setenv("PFLOW_TWO_PHASE_PAIRS", on, 1);
  }
  ~TwoPhase() { unsetenv("PFLOW_TWO_PHASE_PAIRS"); }
};
std::unique_ptr<Simulation> make(const char* inlineSlots, const char* twoPhase = nullptr) {
  InlineSlots scope(inlineSlots);
  TwoPhase phases(twoPhase);
  compute::SimulationOptions o;
  o.pairsOnce = false;
  auto sim = Simulation::create(test::pouredHeap(kR, 2), o);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}
std::map<Gid, Vec3d> byGid(const Simulation& s, const char* field) {
  const auto snap = s.snapshot();
  std::map<Gid, Vec3d> out;
  for (std::size_t k = 0; k < snap.n; ++k) out[snap.find("id")->as<Gid>()[k]] = snap.find(field)->as<Vec3d>()[k];
  return out;
}
// Histories beyond `inlineSlots` a particle, from a run that keeps them all inline.
std::size_t beyond(const Simulation& s, int inlineSlots) {
  const auto state = s.engine().stateArrays(s.stepCount(), 0);
  const compute::SnapshotArray* p = state.find("history_partner");
  std::size_t n = 0;
  for (std::size_t i = 0; i < state.n; ++i) {
    int used = 0;
    for (int k = 0; k < p->components; ++k) used += p->as<PartnerId>()[i * p->components + k] != kNoPartner;
    n += std::size_t(std::max(0, used - inlineSlots));
  }
  return n;
}
void expectIdentical(const Simulation& a, const Simulation& b) {
  for (const char* f : {"position", "velocity", "angular_velocity"}) {
    const auto x = byGid(a, f), y = byGid(b, f);
    ASSERT_EQ(x.size(), y.size());
    int differ = 0;
    for (const auto& [g, v] : x) differ += std::memcmp(&v, &y.at(g), sizeof v) != 0;
    EXPECT_EQ(differ, 0) << f;
  }
}
}  // namespace pool


TEST(History, PoolBeyondInlineSlotsChangesNoResult) {
  auto pooled = pool::make("2"), all = pool::make("0");
  ASSERT_TRUE(pooled && all);
  std::size_t most = 0;
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(pooled->runSteps(1000).isOk());
    ASSERT_TRUE(all->runSteps(1000).isOk());
    EXPECT_EQ(pooled->contactStats().historyEntries, all->contactStats().historyEntries) << "after " << pooled->stepCount();
    most = std::max(most, pool::beyond(*all, 2));
  }
  std::printf("histories beyond two a particle: at most %zu\n", most);
  EXPECT_EQ(pooled->engine().historySlots(), 2);
  EXPECT_GT(all->engine().historySlots(), 4);  // the heap's particles really have more contacts than two
  EXPECT_GT(most, 128u);                       // the pool outgrew the 128 claims of its first table
  EXPECT_GT(pooled->rebuilds(), 5);
  pool::expectIdentical(*pooled, *all);
}

// `make`'s run straight to 3 000 steps; another checkpointed at the first rebuild after 2 000 and resumed to 3 000 in a
// third; `fileSlots`: the checkpoint's slots a particle.
struct StraightAndResumed {
  std::unique_ptr<Simulation> straight, resumed;
  int fileSlots = 0;
};
template <class Make>
void runAndResume(Make make, StraightAndResumed& out) {
  out.straight = make();
  auto first = make();
  out.resumed = make();
  ASSERT_TRUE(out.straight && first && out.resumed);
  ASSERT_TRUE(out.straight->runSteps(3000).isOk());
  ASSERT_TRUE(first->runSteps(2000).isOk());
  while (!first->justRebuilt()) ASSERT_TRUE(first->runSteps(1).isOk());
  auto state = first->state();
  ASSERT_TRUE(state.isOk()) << state.status().toString();
  out.fileSlots = state.value().contactSlots;
  ASSERT_TRUE(out.resumed->resume(state.value()).isOk());
  ASSERT_TRUE(out.resumed->runSteps(3000 - out.resumed->stepCount()).isOk());
}

TEST(History, PooledCheckpointResumesBitForBit) {
  StraightAndResumed r;
  ASSERT_NO_FATAL_FAILURE(runAndResume([] { return pool::make("2"); }, r));
  EXPECT_GT(r.fileSlots, 2);  // the pooled histories went into the file's rows
  pool::expectIdentical(*r.straight, *r.resumed);
}

// The pair kernel's two-phase loop (ComputeForces' kTwoPhase, the GPU's: a piece of candidates tested, then the
// marked ones evaluated) against the one-phase loop, on the CPU: the same sums, the same slots claimed, the same
// pool, so the same run bit for bit, through contacts that start and end and histories pooled beyond two slots.
TEST(History, TwoPhasePairLoopChangesNoResult) {
  auto two = pool::make("2", "1"), one = pool::make("2", "0");
  ASSERT_TRUE(two && one);
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(two->runSteps(1000).isOk());
    ASSERT_TRUE(one->runSteps(1000).isOk());
    EXPECT_EQ(two->contactStats().historyEntries, one->contactStats().historyEntries) << "after " << two->stepCount();
  }
  EXPECT_GT(two->contactStats().historyEntries, 600u);
  pool::expectIdentical(*two, *one);
}

// The same with rows longer than one piece of 32: a sphere of 5 r in the middle of the heap (the lattice's spheres
// where it lies taken out) has about 60 candidates, so that its row is tested in several pieces.
TEST(History, TwoPhasePairLoopOverLongRowsChangesNoResult) {
  auto make = [](const char* twoPhase) -> std::unique_ptr<Simulation> {
    pool::InlineSlots scope("2");
    pool::TwoPhase phases(twoPhase);
    const compute::RunConfig heap = test::pouredHeap(kR, 2);
    compute::RunConfig c = heap;
    c.particles = {};
    const Vec3d centre{10.5 * kR, 10.5 * kR, 6 * kR};
    for (std::size_t k = 0; k < heap.particles.position.size(); ++k)
      if (norm(heap.particles.position[k] - centre) > 6.2 * kR)
        addParticle(c, heap.particles.position[k], heap.particles.radius[k], 0);
    addParticle(c, centre, 5 * kR, 0);
    compute::SimulationOptions o;
    o.pairsOnce = false;
    auto sim = Simulation::create(c, o);
    EXPECT_TRUE(sim.isOk()) << sim.status().toString();
    return sim.isOk() ? std::move(sim).value() : nullptr;
  };
  auto two = make("1"), one = make("0");
  ASSERT_TRUE(two && one);
  ASSERT_TRUE(two->runSteps(1500).isOk());
  ASSERT_TRUE(one->runSteps(1500).isOk());
  std::map<Gid, int> rowLength;
  for (const auto& [a, b] : two->engine().candidatePairs()) ++rowLength[a];  // (i, each of i's candidates)
  int longest = 0;
  for (const auto& [g, n] : rowLength) longest = std::max(longest, n);
  std::printf("longest row: %d candidates\n", longest);
  EXPECT_GT(longest, 40) << "the big sphere's candidates";
  EXPECT_EQ(two->contactStats().historyEntries, one->contactStats().historyEntries);
  pool::expectIdentical(*two, *one);
}


// The GPU's pairs once (ComputeForces' kHalf, PFLOW_GPU_HALF_PAIRS=1: each pair evaluated by its lower index, whose
// row lists only the candidates above it, the reaction added by atomic adds, the history moved to the owner at each
// rebuild), run on the CPU against the CPU's own pairs once (slabs in two colours). The sums are added in another
// order, so the runs part by rounding only: through contacts that start and end and rebuilds that renumber the
// particles, every contact keeps one history (no copy left behind on the partner, none lost: a lost history parts
// the runs by far more, 6e-5 m when the rows' build freed the slots before their owners had taken them), and the
// positions stay within 1e-9 m. With one inline slot the owners' other histories go to the pool, and those of pairs
// whose owner changes are taken over from the pool too.
std::unique_ptr<Simulation> makePairsOnce(bool half, const char* inlineSlots,
                                          compute::Precision precision = compute::Precision::kDouble) {
  pool::TwoPhase phases(half ? "1" : nullptr);
  pool::InlineSlots scope(inlineSlots);
  if (half) setenv("PFLOW_GPU_HALF_PAIRS", "1", 1);
  RunConfig c = test::pouredHeap(kR, 2);
  c.sim.precision = precision;
  auto sim = Simulation::create(c, compute::SimulationOptions{});
  unsetenv("PFLOW_GPU_HALF_PAIRS");
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}
double farthestApart(const Simulation& a, const Simulation& b) {
  const auto x = pool::byGid(a, "position"), y = pool::byGid(b, "position");
  EXPECT_EQ(x.size(), y.size());
  double most = 0;
  for (const auto& [g, v] : x)
    if (y.count(g)) most = std::max(most, norm(v - y.at(g)));
  return most;
}
// `chunks` of 1 000 steps; positions within `apart`, the stored elastic energy within `energy` (relative).
void pairsOnceFollowsTheCpu(const char* inlineSlots, compute::Precision precision = compute::Precision::kDouble,
                            int chunks = 3, double apart = 1e-9, double energy = 1e-9) {
  auto half = makePairsOnce(true, inlineSlots, precision), cpu = makePairsOnce(false, inlineSlots, precision);
  ASSERT_TRUE(half && cpu);
  for (int k = 0; k < chunks; ++k) {
    ASSERT_TRUE(half->runSteps(1000).isOk());
    ASSERT_TRUE(cpu->runSteps(1000).isOk());
    const auto h = half->contactStats(), c = cpu->contactStats();
    std::printf("after %lld steps: %zu and %zu contacts, %zu and %zu histories, %d inline slots\n",
                (long long)half->stepCount(), h.particleContacts, c.particleContacts, h.historyEntries, c.historyEntries,
                half->engine().historySlots());
    EXPECT_EQ(h.particleContacts, c.particleContacts);
    EXPECT_EQ(h.historyEntries, c.historyEntries);
    // The diagnostics read every pair from both rows (the host's copy of the upper rows made whole): the stored
    // elastic energy that the energy check allows for, and the candidates a particle.
    EXPECT_NEAR(half->engine().elasticEnergy(), cpu->engine().elasticEnergy(), energy * cpu->engine().elasticEnergy());
    EXPECT_DOUBLE_EQ(h.candidatesPerParticle, c.candidatesPerParticle);
  }
  EXPECT_GT(half->rebuilds(), 2 * chunks - 1);
  EXPECT_GT(half->contactStats().historyEntries, chunks * 200u);
  if (std::atoi(inlineSlots) > 0) {  // owners with more histories than the inline slots: the pool holds the rest
    std::printf("the CPU's owners hold %zu histories beyond %s a particle\n", pool::beyond(*cpu, std::atoi(inlineSlots)), inlineSlots);
    EXPECT_GT(pool::beyond(*cpu, std::atoi(inlineSlots)), 100u);
    EXPECT_EQ(half->engine().historySlots(), std::atoi(inlineSlots));
  }
  const double most = farthestApart(*half, *cpu);
  std::printf("positions apart by at most %.3g m\n", most);
  EXPECT_LT(most, apart);
}
TEST(History, GpuPairsOnceFollowsTheCpuPairsOnce) { pairsOnceFollowsTheCpu("0"); }
TEST(History, GpuPairsOnceWithThePoolFollowsTheCpuPairsOnce) { pairsOnceFollowsTheCpu("1"); }
// In float the sums are 16-byte rows (Sum4), added to and copied out (FinishSums), and the GPU's pairs once takes the
// overlap as (rs^2 - d^2) / (rs + d) where the CPU's takes rs - d (pairState's kFloatOverlap: they round differently).
// Float's rounding parts the runs sooner: over the first 1 000 steps (2.1e-9 m apart; 6.4e-10 with the same formula).
TEST(History, GpuPairsOnceInFloatFollowsTheCpuPairsOnce) {
  pairsOnceFollowsTheCpu("0", compute::Precision::kFloat, 1, 1e-8, 1e-6);
}

// A checkpoint of the GPU's pairs once (the owners' histories, pooled ones merged into the file's rows) resumes into
// a run that follows the uninterrupted one: to rounding, not bit for bit (its atomic sums have no fixed order).
TEST(History, GpuPairsOnceResumesFromACheckpoint) {
  StraightAndResumed r;
  ASSERT_NO_FATAL_FAILURE(runAndResume([] { return makePairsOnce(true, "1"); }, r));
  EXPECT_GT(r.fileSlots, 1);  // the pooled histories went into the file's rows
  EXPECT_EQ(r.resumed->contactStats().historyEntries, r.straight->contactStats().historyEntries);
  const double most = farthestApart(*r.straight, *r.resumed);
  std::printf("resumed and uninterrupted apart by at most %.3g m\n", most);
  EXPECT_LT(most, 1e-9);
}

}  // namespace
}  // namespace pflow::test
