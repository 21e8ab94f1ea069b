// What a node offers to jobs: its GPUs (through NVML, loaded at run time) or, where there is none, CPU slots.
// No gRPC here: the adapter turns DeviceInfo into pflow.manager.v1.Device.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pflow::agent {

enum class DeviceKind { kGpu, kCpu };

const char* deviceKindName(DeviceKind kind);  // "gpu" / "cpu" (as in the worker's --devices list)

// One device as the agent measured it. Zero means "unknown" for utilisation and temperature.
struct DeviceInfo {
  DeviceKind kind = DeviceKind::kCpu;
  int index = 0;                    // CUDA ordinal (NVML index; the worker runs with CUDA_DEVICE_ORDER=PCI_BUS_ID) or CPU slot
  std::string name;                 // "NVIDIA H100 80GB HBM3", "CPU slot (16 cores)"
  std::uint64_t memoryTotalBytes = 0;
  std::uint64_t memoryUsedBytes = 0;
  double utilization = 0;           // 0..1
  double temperatureC = 0;          // 0 = unknown
};

class DeviceProbe {
 public:
  virtual ~DeviceProbe() = default;
  // The devices now (called on every heartbeat; cheap). Empty when there are none or the probe cannot see them.
  virtual std::vector<DeviceInfo> probe() = 0;
  virtual std::string describe() const = 0;  // one line for the log: what this probe is and what it found
};

// GPUs through NVML. libnvidia-ml.so.1 comes with the NVIDIA driver, so it is dlopen'ed at run time: the agent has no
// link-time dependency and runs (reporting no GPU, with a reason) where the driver is absent.
class NvmlProbe final : public DeviceProbe {
 public:
  explicit NvmlProbe(std::string library = "libnvidia-ml.so.1");
  ~NvmlProbe() override;
  NvmlProbe(const NvmlProbe&) = delete;
  NvmlProbe& operator=(const NvmlProbe&) = delete;

  bool available() const { return m_ready; }
  const std::string& reason() const { return m_reason; }  // why it is not available ("" when it is)
  int deviceCount() const { return m_count; }
  std::vector<DeviceInfo> probe() override;
  std::string describe() const override;

 private:
  struct Api;
  std::unique_ptr<Api> m_api;
  void* m_handle = nullptr;
  bool m_initialized = false;  // nvmlInit_v2 succeeded: nvmlShutdown at the end
  bool m_ready = false;
  int m_count = 0;
  std::string m_reason;
};

// K CPU slots for a node without GPUs. Each slot reports its share (1/K) of the node's memory (/proc/meminfo) and
// the node's load (1-minute load average / cores, capped at 1) as utilisation.
class CpuProbe final : public DeviceProbe {
 public:
  // `procRoot` is where meminfo and loadavg are read (tests point it at a fake). cores = 0: this machine's count.
  explicit CpuProbe(int slots = 1, std::string procRoot = "/proc", int cores = 0);
  std::vector<DeviceInfo> probe() override;
  std::string describe() const override;
  int slots() const { return m_slots; }
  int cores() const { return m_cores; }

 private:
  int m_slots;
  std::string m_procRoot;
  int m_cores;
};

// The agent's choice: GPUs when NVML finds at least one (unless forceCpu), else CPU slots. Logs why.
std::unique_ptr<DeviceProbe> chooseProbe(bool forceCpu, int cpuSlots, const std::string& nvmlLibrary = "libnvidia-ml.so.1");

}  // namespace pflow::agent
