// The CPU's batched contact law (compute/dem/contact/ContactBatch.h: the pairs once evaluated a batch of contacts at a
// time in SIMD lanes) gives the bits of evaluating one contact at a time, over a poured heap whose grains change
// partners, owners and slots, in both precisions and in every loop the least model picks: friction and rolling
// resistance, friction only, rolling only, neither; two materials (a batch holds one material pair, so it is evaluated
// early where the pair changes), and a floor of fixed grains (ContactParams::fixedSide).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

constexpr double kR = 1e-3;

struct Variant {
  std::string name;
  compute::Precision precision;
  double friction, rolling;
  bool twoMaterials, fixedFloor;
};

RunConfig scene(const Variant& v) {
  RunConfig c = pouredHeap(kR, 2);
  c.sim.precision = v.precision;
  c.materials[0].friction = v.friction;
  c.materials[0].rollingFriction = v.rolling;
  if (v.twoMaterials) {  // every third grain of a second material: other stiffness, friction and no rolling resistance
    c.materials.push_back(material("b", 3e7, 0.25, 2000, 0.7, v.friction > 0 ? 0.3 : 0, 0));
    for (std::size_t k = 0; k < c.particles.material.size(); k += 3) c.particles.material[k] = 1;
  }
  if (v.fixedFloor) {  // the bottom layer glued where it starts
    c.materials.push_back(material("glued", 1e7, 0.3, 2500, 0.5, v.friction, v.rolling));
    c.materials.back().fixed = true;
    const int fixedMat = int(c.materials.size()) - 1;
    for (std::size_t k = 0; k < 100; ++k) c.particles.material[k] = fixedMat;
  }
  return c;
}

std::unique_ptr<Simulation> make(const Variant& v, bool batched) {
  compute::SimulationOptions o;
  o.batchedContacts = batched;
  auto sim = Simulation::create(scene(v), o);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}

// Bit for bit, field by field, in the snapshots' order (both runs order their particles alike).
void expectSameBits(const Simulation& a, const Simulation& b) {
  const auto x = a.snapshot(), y = b.snapshot();
  ASSERT_EQ(x.n, y.n);
  for (const char* f : {"position", "velocity", "angular_velocity", "force"}) {
    const auto* p = x.find(f);
    const auto* q = y.find(f);
    ASSERT_TRUE(p && q) << f;
    ASSERT_EQ(p->data.size(), q->data.size()) << f;
    EXPECT_EQ(std::memcmp(p->data.data(), q->data.data(), p->data.size()), 0) << f << " differs";
  }
}

class BatchedContacts : public ::testing::TestWithParam<Variant> {};

TEST_P(BatchedContacts, SameBitsAsOneContactAtATime) {
  const Variant& v = GetParam();
  auto batched = make(v, true), single = make(v, false);
  ASSERT_TRUE(batched && single);
  for (int chunk = 0; chunk < 4; ++chunk) {
    ASSERT_TRUE(batched->runSteps(1000).isOk());
    ASSERT_TRUE(single->runSteps(1000).isOk());
    expectSameBits(*batched, *single);
    EXPECT_EQ(batched->contactStats().historyEntries, single->contactStats().historyEntries);
  }
  std::printf("%zu contacts, %ld rebuilds\n", batched->contactStats().particleContacts, batched->rebuilds());
  EXPECT_GT(batched->contactStats().particleContacts, 250u);  // a heap: most grains touch, the batches fill
  EXPECT_GT(batched->rebuilds(), 2);
}

INSTANTIATE_TEST_SUITE_P(
    Models, BatchedContacts,
    ::testing::Values(Variant{"FrictionAndRolling", compute::Precision::kDouble, 0.5, 0.05, false, false},
                      Variant{"FrictionAndRollingFloat", compute::Precision::kFloat, 0.5, 0.05, false, false},
                      Variant{"FrictionOnly", compute::Precision::kDouble, 0.5, 0, false, false},
                      Variant{"RollingOnly", compute::Precision::kDouble, 0, 0.05, false, false},
                      Variant{"Frictionless", compute::Precision::kDouble, 0, 0, false, false},
                      Variant{"FrictionlessFloat", compute::Precision::kFloat, 0, 0, false, false},
                      Variant{"TwoMaterials", compute::Precision::kDouble, 0.5, 0.05, true, false},
                      Variant{"FixedFloor", compute::Precision::kDouble, 0.5, 0.05, false, true},
                      Variant{"FixedFloorFloat", compute::Precision::kFloat, 0.5, 0.05, false, true}),
    [](const ::testing::TestParamInfo<Variant>& info) { return info.param.name; });

}  // namespace
}  // namespace pflow::test
