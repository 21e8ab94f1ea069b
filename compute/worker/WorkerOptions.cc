#include "compute/worker/WorkerOptions.h"

#include <charconv>

namespace pflow::worker {

Result<std::vector<LeasedDevice>> parseDevices(const std::string& list) {
  std::vector<LeasedDevice> out;
  std::size_t start = 0;
  while (start <= list.size() && !list.empty()) {
    std::size_t end = list.find(',', start);
    if (end == std::string::npos) end = list.size();
    const std::string entry = list.substr(start, end - start);
    const auto a = entry.find(':'), b = entry.rfind(':');
    if (a == std::string::npos || a == b)
      return invalidArgument("--devices entry '" + entry + "': expected node:kind:index (e.g. gpu01:gpu:0)");
    LeasedDevice d{entry.substr(0, a), entry.substr(a + 1, b - a - 1), 0};
    const std::string idx = entry.substr(b + 1);
    const auto [p, ec] = std::from_chars(idx.data(), idx.data() + idx.size(), d.index);
    if (ec != std::errc() || p != idx.data() + idx.size() || d.index < 0)
      return invalidArgument("--devices entry '" + entry + "': index '" + idx + "' is not an integer >= 0");
    if (d.kind != "gpu" && d.kind != "cpu") return invalidArgument("--devices entry '" + entry + "': kind must be gpu or cpu");
    if (d.node.empty()) return invalidArgument("--devices entry '" + entry + "': empty node name");
    out.push_back(std::move(d));
    start = end + 1;
  }
  return out;
}

Result<LeasedDevice> slurmDevice(const std::string& kind, const char* (*env)(const char*)) {
  if (kind != "gpu" && kind != "cpu") return invalidArgument("--devices slurm:" + kind + ": kind must be gpu or cpu");
  const char* node = env("SLURMD_NODENAME");
  const char* local = env("SLURM_LOCALID");
  if (!node || !*node || !local)
    return invalidArgument("--devices slurm:" + kind + ": SLURMD_NODENAME and SLURM_LOCALID are not set (start the worker with srun)");
  LeasedDevice d{node, kind, 0};
  const std::string localId = local;
  const auto [p, ec] = std::from_chars(localId.data(), localId.data() + localId.size(), d.index);
  if (ec != std::errc() || p != localId.data() + localId.size() || d.index < 0)
    return invalidArgument("--devices slurm:" + kind + ": SLURM_LOCALID '" + localId + "' is not an integer >= 0");
  if (kind == "gpu") {
    const char* visible = env("CUDA_VISIBLE_DEVICES");
    if (visible && *visible && std::string(visible).find(',') == std::string::npos) d.index = 0;  // its own GPU only
  }
  return d;
}

}  // namespace pflow::worker
