// Placement: thresholds, GPU vs CPU, one node vs spanning, wait vs never fits.
#include "manager/Placement.h"

#include <gtest/gtest.h>

namespace pflow::manager {
namespace {

NodeView node(const std::string& name, int gpus, int cpus = 0, std::uint64_t memory = 80ull << 30) {
  NodeView n;
  n.name = name;
  n.agentAddress = name + ":7000";
  for (int i = 0; i < gpus; ++i) n.devices.push_back({{{name, i, DeviceKind::kGpu}, "GPU", memory, 0, 0, 0}, DeviceState::kFree, ""});
  for (int i = 0; i < cpus; ++i) n.devices.push_back({{{name, i, DeviceKind::kCpu}, "CPU", memory, 0, 0, 0}, DeviceState::kFree, ""});
  return n;
}

void busy(NodeView& n, int index, DeviceKind kind = DeviceKind::kGpu) {
  for (DeviceView& d : n.devices)
    if (d.info.key.index == index && d.info.key.kind == kind) {
      d.state = DeviceState::kBusy;
      d.jobId = "other";
    }
}

std::vector<DeviceKey> gpus(const std::string& node, std::vector<int> idx) {
  std::vector<DeviceKey> out;
  for (int i : idx) out.push_back({node, i, DeviceKind::kGpu});
  return out;
}

// 250000 per GPU, 50000 per CPU slot: set here, not taken from the defaults (which are measurements), so
// these tests pin the rule.
PlacementThresholds testThresholds() {
  PlacementThresholds t;
  t.particlesPerGpu = 250000;
  t.particlesPerCpuSlot = 50000;
  return t;
}
const PlacementThresholds kTh = testThresholds();

TEST(Placement, CountIsParticlesOverThresholdRoundedDown) {
  const std::vector<NodeView> nodes{node("a", 8)};
  EXPECT_EQ(place({10, 0, 0}, nodes, kTh).count, 1);          // tiny: one device
  EXPECT_EQ(place({249999, 0, 0}, nodes, kTh).count, 1);
  EXPECT_EQ(place({499999, 0, 0}, nodes, kTh).count, 1);      // two would get < 250000 each
  EXPECT_EQ(place({500000, 0, 0}, nodes, kTh).count, 2);
  const Placement p = place({1000000, 0, 0}, nodes, kTh);
  ASSERT_EQ(p.outcome, PlacementOutcome::kPlaced);
  EXPECT_EQ(p.kind, DeviceKind::kGpu);
  EXPECT_EQ(p.devices, gpus("a", {0, 1, 2, 3}));
}

TEST(Placement, ThresholdsAreSettings) {
  PlacementThresholds th;
  th.particlesPerGpu = 100000;
  EXPECT_EQ(place({1000000, 0, 0}, {node("a", 16)}, th).count, 10);
}

TEST(Placement, MaxDevicesAndExistingDevicesCapTheCount) {
  EXPECT_EQ(place({1000000, 0, 2}, {node("a", 8)}, kTh).count, 2);
  const Placement p = place({100000000, 0, 0}, {node("a", 4)}, kTh);  // deserves 400, 4 exist
  EXPECT_EQ(p.outcome, PlacementOutcome::kPlaced);
  EXPECT_EQ(p.count, 4);
}

TEST(Placement, PrefersGpusOverCpuSlots) {
  const Placement p = place({200000, 0, 0}, {node("a", 2), node("b", 0, 16)}, kTh);
  ASSERT_EQ(p.outcome, PlacementOutcome::kPlaced);
  EXPECT_EQ(p.kind, DeviceKind::kGpu);
  EXPECT_EQ(p.devices, gpus("a", {0}));
}

TEST(Placement, CpuSlotsWhenNoNodeHasAGpu) {
  const Placement p = place({200000, 0, 0}, {node("c", 0, 8)}, kTh);
  ASSERT_EQ(p.outcome, PlacementOutcome::kPlaced);
  EXPECT_EQ(p.kind, DeviceKind::kCpu);
  EXPECT_EQ(p.count, 4);  // 200000 / 50000
  for (const DeviceKey& d : p.devices) EXPECT_EQ(d.kind, DeviceKind::kCpu);
}

TEST(Placement, GpuJobWaitsForGpusRatherThanTakingCpuSlots) {
  NodeView a = node("a", 2, 8);  // CPU slots on a GPU node are not used
  busy(a, 0);
  busy(a, 1);
  const Placement p = place({100, 0, 0}, {a, node("c", 0, 8)}, kTh);
  EXPECT_EQ(p.outcome, PlacementOutcome::kWait);
  EXPECT_EQ(p.kind, DeviceKind::kGpu);
  EXPECT_NE(p.reason.find("0 of 2 are free"), std::string::npos) << p.reason;
}

TEST(Placement, BestFitSingleNode) {
  NodeView a = node("a", 4);
  NodeView b = node("b", 4);
  busy(b, 0);
  busy(b, 2);  // b has 1 and 3 free
  const Placement p = place({500000, 0, 0}, {a, b}, kTh);
  ASSERT_EQ(p.outcome, PlacementOutcome::kPlaced);
  EXPECT_EQ(p.devices, gpus("b", {1, 3}));
}

TEST(Placement, SpansNodesMostFreeFirst) {
  NodeView a = node("a", 4);
  busy(a, 0);
  busy(a, 1);  // 2 free
  NodeView b = node("b", 4);
  busy(b, 3);  // 3 free
  const Placement p = place({1000000, 0, 0}, {a, b}, kTh);  // 4 GPUs
  ASSERT_EQ(p.outcome, PlacementOutcome::kPlaced);
  std::vector<DeviceKey> want = gpus("b", {0, 1, 2});
  want.push_back({"a", 2, DeviceKind::kGpu});
  EXPECT_EQ(p.devices, want);
}

TEST(Placement, WaitsWhenTooFewAreFree) {
  NodeView a = node("a", 4);
  busy(a, 0);
  busy(a, 1);
  busy(a, 2);
  const Placement p = place({500000, 0, 0}, {a}, kTh);
  EXPECT_EQ(p.outcome, PlacementOutcome::kWait);
  EXPECT_EQ(p.count, 2);
  EXPECT_NE(p.reason.find("needs 2 GPUs; 1 of 4 are free"), std::string::npos) << p.reason;
}

TEST(Placement, MemoryRaisesTheCount) {
  // 25 GB on 10 GB devices (90 % usable): 3 devices though the particle count deserves 1.
  const Placement p = place({10, 25e9, 0}, {node("a", 8, 0, 10'000'000'000ull)}, kTh);
  ASSERT_EQ(p.outcome, PlacementOutcome::kPlaced);
  EXPECT_EQ(p.count, 3);
}

TEST(Placement, NeverFitsWhenTooFewExist) {
  const Placement p = place({10, 100e9, 0}, {node("a", 4, 0, 10'000'000'000ull)}, kTh);
  EXPECT_EQ(p.outcome, PlacementOutcome::kNeverFits);
  EXPECT_NE(p.reason.find("needs at least 12 GPUs but only 4 exist"), std::string::npos) << p.reason;
}

TEST(Placement, NeverFitsWhenMaxDevicesIsBelowTheMemoryMinimum) {
  const Placement p = place({10, 25e9, 2}, {node("a", 8, 0, 10'000'000'000ull)}, kTh);
  EXPECT_EQ(p.outcome, PlacementOutcome::kNeverFits);
  EXPECT_NE(p.reason.find("max_devices is 2"), std::string::npos) << p.reason;
}

TEST(Placement, NeverFitsWithoutDevices) {
  EXPECT_EQ(place({10, 0, 0}, {}, kTh).outcome, PlacementOutcome::kNeverFits);
  NodeView lost = node("a", 4);
  lost.lost = true;
  const Placement p = place({10, 0, 0}, {lost}, kTh);
  EXPECT_EQ(p.outcome, PlacementOutcome::kNeverFits);
  EXPECT_NE(p.reason.find("no devices"), std::string::npos);
}

TEST(Placement, FallsBackToCpuWhenGpusCanNeverHoldIt) {
  // 30 GB model: the 8 GB GPUs (4 of them) cannot hold it, the 64 GB CPU-only node can.
  const Placement p = place({10, 30e9, 0}, {node("g", 4, 0, 8'000'000'000ull), node("c", 0, 4, 64'000'000'000ull)}, kTh);
  ASSERT_EQ(p.outcome, PlacementOutcome::kPlaced);
  EXPECT_EQ(p.kind, DeviceKind::kCpu);
}

}  // namespace
}  // namespace pflow::manager
