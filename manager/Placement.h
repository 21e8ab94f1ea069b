// Placement: a pure function from (job size, limits, inventory snapshot, thresholds) to the devices a job gets,
// or "wait" (too few free now), or "never fits" (too few exist at all). The rule (manager/README.md):
//
//  1. Kind: GPUs when the cluster's live nodes have any GPU that could hold the job; otherwise CPU slots of nodes
//     without GPUs. The kind follows what exists, not what is free, so a GPU job never drifts onto CPUs while GPUs
//     are busy.
//  2. Count: n = max(1, floor(particles / particles_per_device)) -- every device gets at least the threshold, so
//     each one is kept busy -- raised to the memory minimum ceil(memory / (headroom * smallest device memory)),
//     capped by max_devices (when > 0) and by the number of devices of that kind that exist.
//     Never fits when the memory minimum exceeds max_devices or the devices that exist.
//  3. Devices: when fewer than n are free -> wait. Otherwise, the node with the fewest free devices that still
//     holds all n (best fit, then by name); else span nodes, most free first (then by name), lowest indices first.
//     Ranks follow that order.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "manager/Types.h"

namespace pflow::manager {

struct PlacementThresholds {
  // Enough to keep one GPU busy: measured on an H100 (bench/RESULTS.md, "Throughput against size"), one GPU
  // reaches 83-89 % of its large-bed throughput at 10^6 spheres, and under half of it below 2*10^5.
  std::uint64_t particlesPerGpu = 1000000;
  std::uint64_t particlesPerCpuSlot = 50000;  // enough to keep one CPU slot busy
  double memoryHeadroom = 0.9;                // usable fraction of a device's memory
};

struct PlacementRequest {
  std::uint64_t particles = 0;
  double memoryBytes = 0;  // the model on one device; 0 = unknown (no memory minimum)
  int maxDevices = 0;      // 0 = no limit
};

enum class PlacementOutcome { kPlaced, kWait, kNeverFits };

struct Placement {
  PlacementOutcome outcome = PlacementOutcome::kNeverFits;
  DeviceKind kind = DeviceKind::kGpu;
  int count = 0;                    // devices the job gets (placed) or waits for (wait)
  std::vector<DeviceKey> devices;   // when placed, in rank order
  std::string reason;               // why it waits or never fits (for users)
};

Placement place(const PlacementRequest& request, const std::vector<NodeView>& nodes, const PlacementThresholds& thresholds);

}  // namespace pflow::manager
