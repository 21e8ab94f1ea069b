#include "manager/Placement.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

namespace pflow::manager {
namespace {

std::string plural(std::int64_t n, const std::string& what) {
  return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
}

std::string gigabytes(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g GB", bytes / 1e9);
  return buf;
}

std::string kindWord(DeviceKind kind) { return kind == DeviceKind::kGpu ? "GPU" : "CPU slot"; }

// Devices of one kind on live nodes; CPU slots only from nodes without GPUs.
struct Pool {
  std::vector<const DeviceView*> all;
  std::map<std::string, std::vector<const DeviceView*>> freeByNode;
  std::size_t freeCount = 0;
  std::uint64_t smallestMemory = 0;  // over devices reporting it; 0 = none does
};

Pool poolOf(DeviceKind kind, const std::vector<NodeView>& nodes) {
  Pool p;
  for (const NodeView& n : nodes) {
    if (n.lost) continue;
    const bool hasGpu = std::any_of(n.devices.begin(), n.devices.end(),
                                    [](const DeviceView& d) { return d.info.key.kind == DeviceKind::kGpu; });
    if (kind == DeviceKind::kCpu && hasGpu) continue;
    for (const DeviceView& d : n.devices) {
      if (d.info.key.kind != kind) continue;
      p.all.push_back(&d);
      if (d.info.memoryTotalBytes > 0)
        p.smallestMemory = p.smallestMemory == 0 ? d.info.memoryTotalBytes : std::min(p.smallestMemory, d.info.memoryTotalBytes);
      if (d.state == DeviceState::kFree) {
        p.freeByNode[n.name].push_back(&d);
        ++p.freeCount;
      }
    }
  }
  for (auto& [node, devs] : p.freeByNode)
    std::sort(devs.begin(), devs.end(), [](const DeviceView* a, const DeviceView* b) { return a->info.key.index < b->info.key.index; });
  return p;
}

}  // namespace

Placement place(const PlacementRequest& req, const std::vector<NodeView>& nodes, const PlacementThresholds& th) {
  Placement out;
  std::string whyNot;
  for (DeviceKind kind : {DeviceKind::kGpu, DeviceKind::kCpu}) {
    Pool pool = poolOf(kind, nodes);
    if (pool.all.empty()) continue;
    const std::int64_t exist = static_cast<std::int64_t>(pool.all.size());
    std::int64_t minimum = 1;
    if (req.memoryBytes > 0 && pool.smallestMemory > 0) {
      const double usable = th.memoryHeadroom * static_cast<double>(pool.smallestMemory);
      minimum = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(req.memoryBytes / usable)));
    }
    if (req.maxDevices > 0 && minimum > req.maxDevices) {
      whyNot += std::string(whyNot.empty() ? "" : "; ") + "the model (" + gigabytes(req.memoryBytes) + ") needs at least " + plural(minimum, kindWord(kind)) + " but max_devices is " + std::to_string(req.maxDevices);
      continue;
    }
    if (minimum > exist) {
      whyNot += std::string(whyNot.empty() ? "" : "; ") + "the model (" + gigabytes(req.memoryBytes) + ") needs at least " + plural(minimum, kindWord(kind)) + " but only " + std::to_string(exist) + " exist";
      continue;
    }
    const std::uint64_t perDevice = std::max<std::uint64_t>(1, kind == DeviceKind::kGpu ? th.particlesPerGpu : th.particlesPerCpuSlot);
    const std::uint64_t deserved = std::max<std::uint64_t>(1, req.particles / perDevice);
    std::int64_t n = static_cast<std::int64_t>(std::min<std::uint64_t>(deserved, static_cast<std::uint64_t>(std::numeric_limits<int>::max())));
    n = std::max(n, minimum);
    if (req.maxDevices > 0) n = std::min<std::int64_t>(n, req.maxDevices);
    n = std::min(n, exist);

    out.kind = kind;
    out.count = static_cast<int>(n);
    if (static_cast<std::int64_t>(pool.freeCount) < n) {
      out.outcome = PlacementOutcome::kWait;
      out.reason = "needs " + plural(n, kindWord(kind)) + "; " + std::to_string(pool.freeCount) + " of " +
                   std::to_string(exist) + " are free";
      return out;
    }

    // One node if any holds all n: the one with the fewest free devices that does (best fit), then by name.
    const std::vector<const DeviceView*>* single = nullptr;
    for (const auto& [node, devs] : pool.freeByNode)
      if (static_cast<std::int64_t>(devs.size()) >= n && (!single || devs.size() < single->size())) single = &devs;
    if (single) {
      for (std::int64_t i = 0; i < n; ++i) out.devices.push_back((*single)[i]->info.key);
    } else {
      std::vector<const std::vector<const DeviceView*>*> order;
      for (const auto& [node, devs] : pool.freeByNode) order.push_back(&devs);
      std::stable_sort(order.begin(), order.end(), [](auto* a, auto* b) { return a->size() > b->size(); });
      for (auto* devs : order)
        for (const DeviceView* d : *devs)
          if (static_cast<std::int64_t>(out.devices.size()) < n) out.devices.push_back(d->info.key);
    }
    out.outcome = PlacementOutcome::kPlaced;
    return out;
  }
  out.outcome = PlacementOutcome::kNeverFits;
  out.reason = whyNot.empty() ? "no devices: no live node has reported a GPU or a CPU slot" : whyNot;
  return out;
}

}  // namespace pflow::manager
