#include "manager/agent/Devices.h"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <thread>

#include "common/Log.h"

namespace pflow::agent {

const char* deviceKindName(DeviceKind kind) { return kind == DeviceKind::kGpu ? "gpu" : "cpu"; }

// --- NVML ------------------------------------------------------------------------------------------------------------
// The few NVML declarations the probe needs, written from the NVML API reference (docs.nvidia.com/deploy/nvml-api):
// nvmlReturn_t is an enum whose success value is 0; a device handle is an opaque pointer; nvmlMemory_t holds total,
// free and used bytes (unsigned long long, in that order); nvmlUtilization_t holds the gpu and memory percentages
// (unsigned int); temperature sensor 0 is NVML_TEMPERATURE_GPU; 96 bytes hold any device name
// (NVML_DEVICE_NAME_V2_BUFFER_SIZE). The functions are C functions of the driver's libnvidia-ml.so.1.
namespace {
using NvmlReturn = int;
constexpr NvmlReturn kNvmlSuccess = 0;
using NvmlDevice = struct NvmlDeviceOpaque*;
struct NvmlMemory {
  unsigned long long total;
  unsigned long long free;
  unsigned long long used;
};
struct NvmlUtilization {
  unsigned int gpu;
  unsigned int memory;
};
constexpr int kNvmlTemperatureGpu = 0;
constexpr unsigned kNvmlNameBufferSize = 96;
}  // namespace

struct NvmlProbe::Api {
  NvmlReturn (*init)() = nullptr;                                         // nvmlInit_v2
  NvmlReturn (*shutdown)() = nullptr;                                     // nvmlShutdown
  NvmlReturn (*getCount)(unsigned int*) = nullptr;                        // nvmlDeviceGetCount_v2
  NvmlReturn (*getHandle)(unsigned int, NvmlDevice*) = nullptr;           // nvmlDeviceGetHandleByIndex_v2
  NvmlReturn (*getName)(NvmlDevice, char*, unsigned int) = nullptr;       // nvmlDeviceGetName
  NvmlReturn (*getMemory)(NvmlDevice, NvmlMemory*) = nullptr;             // nvmlDeviceGetMemoryInfo
  NvmlReturn (*getUtilization)(NvmlDevice, NvmlUtilization*) = nullptr;   // nvmlDeviceGetUtilizationRates
  NvmlReturn (*getTemperature)(NvmlDevice, int, unsigned int*) = nullptr; // nvmlDeviceGetTemperature
  const char* (*errorString)(NvmlReturn) = nullptr;                       // nvmlErrorString (optional)

  std::string error(NvmlReturn r) const {
    std::string s = "NVML error " + std::to_string(r);
    if (errorString) {
      if (const char* text = errorString(r)) s += " (" + std::string(text) + ")";
    }
    return s;
  }
};

namespace {
template <class F>
bool resolve(void* handle, const char* name, F& fn, std::string& missing) {
  fn = reinterpret_cast<F>(dlsym(handle, name));
  if (!fn) {
    if (!missing.empty()) missing += ", ";
    missing += name;
  }
  return fn != nullptr;
}
}  // namespace

NvmlProbe::NvmlProbe(std::string library) : m_api(std::make_unique<Api>()) {
  m_handle = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!m_handle) {
    const char* e = dlerror();
    m_reason = "cannot load " + library + ": " + (e ? e : "unknown error") + " (no NVIDIA driver on this node?)";
    return;
  }
  std::string missing;
  Api& a = *m_api;
  resolve(m_handle, "nvmlInit_v2", a.init, missing);
  resolve(m_handle, "nvmlShutdown", a.shutdown, missing);
  resolve(m_handle, "nvmlDeviceGetCount_v2", a.getCount, missing);
  resolve(m_handle, "nvmlDeviceGetHandleByIndex_v2", a.getHandle, missing);
  resolve(m_handle, "nvmlDeviceGetName", a.getName, missing);
  resolve(m_handle, "nvmlDeviceGetMemoryInfo", a.getMemory, missing);
  resolve(m_handle, "nvmlDeviceGetUtilizationRates", a.getUtilization, missing);
  resolve(m_handle, "nvmlDeviceGetTemperature", a.getTemperature, missing);
  std::string optionalMissing;
  resolve(m_handle, "nvmlErrorString", a.errorString, optionalMissing);
  if (!missing.empty()) {
    m_reason = library + " lacks " + missing;
    return;
  }
  if (NvmlReturn r = a.init(); r != kNvmlSuccess) {
    m_reason = "nvmlInit_v2 failed: " + a.error(r);
    return;
  }
  m_initialized = true;
  unsigned int count = 0;
  if (NvmlReturn r = a.getCount(&count); r != kNvmlSuccess) {
    m_reason = "nvmlDeviceGetCount_v2 failed: " + a.error(r);
    return;
  }
  m_count = static_cast<int>(count);
  m_ready = true;
  if (m_count == 0) m_reason = "NVML sees no GPU";
}

NvmlProbe::~NvmlProbe() {
  if (m_initialized) m_api->shutdown();
  if (m_handle) dlclose(m_handle);
}

std::vector<DeviceInfo> NvmlProbe::probe() {
  std::vector<DeviceInfo> out;
  if (!m_ready) return out;
  const Api& a = *m_api;
  for (int i = 0; i < m_count; ++i) {
    NvmlDevice dev = nullptr;
    if (NvmlReturn r = a.getHandle(static_cast<unsigned>(i), &dev); r != kNvmlSuccess) {
      spdlog::warn("NVML: GPU {}: {}", i, a.error(r));
      continue;
    }
    DeviceInfo d;
    d.kind = DeviceKind::kGpu;
    d.index = i;
    char name[kNvmlNameBufferSize] = {};
    d.name = a.getName(dev, name, sizeof name) == kNvmlSuccess ? std::string(name) : "NVIDIA GPU";
    NvmlMemory mem{};
    if (a.getMemory(dev, &mem) == kNvmlSuccess) {
      d.memoryTotalBytes = mem.total;
      d.memoryUsedBytes = mem.used;
    }
    NvmlUtilization util{};
    if (a.getUtilization(dev, &util) == kNvmlSuccess) d.utilization = std::min(1.0, util.gpu / 100.0);
    unsigned int temp = 0;
    if (a.getTemperature(dev, kNvmlTemperatureGpu, &temp) == kNvmlSuccess) d.temperatureC = temp;
    out.push_back(std::move(d));
  }
  return out;
}

std::string NvmlProbe::describe() const {
  if (!m_ready) return "NVML unavailable: " + m_reason;
  return "NVML: " + std::to_string(m_count) + " GPU(s)";
}

// --- CPU slots -------------------------------------------------------------------------------------------------------
namespace {
// A "Key:   value kB" line of /proc/meminfo, in bytes; 0 when absent.
std::uint64_t meminfoBytes(const std::string& text, const std::string& key) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key + ":", 0) != 0) continue;
    std::istringstream fields(line.substr(key.size() + 1));
    std::uint64_t value = 0;
    std::string unit;
    fields >> value >> unit;
    return unit == "kB" ? value * 1024 : value;
  }
  return 0;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

CpuProbe::CpuProbe(int slots, std::string procRoot, int cores)
    : m_slots(std::max(1, slots)), m_procRoot(std::move(procRoot)), m_cores(cores) {
  if (m_cores <= 0) {
    const long n = sysconf(_SC_NPROCESSORS_ONLN);
    m_cores = n > 0 ? static_cast<int>(n) : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  }
}

std::vector<DeviceInfo> CpuProbe::probe() {
  const std::string meminfo = readAll(m_procRoot + "/meminfo");
  const std::uint64_t total = meminfoBytes(meminfo, "MemTotal");
  std::uint64_t available = meminfoBytes(meminfo, "MemAvailable");
  if (available == 0) available = meminfoBytes(meminfo, "MemFree");  // kernels before 3.14
  const std::uint64_t used = total > available ? total - available : 0;

  double load1 = 0;
  std::istringstream(readAll(m_procRoot + "/loadavg")) >> load1;
  const double utilization = std::clamp(load1 / m_cores, 0.0, 1.0);

  std::vector<DeviceInfo> out;
  for (int s = 0; s < m_slots; ++s) {
    DeviceInfo d;
    d.kind = DeviceKind::kCpu;
    d.index = s;
    d.name = "CPU slot (" + std::to_string(m_cores) + " cores)";
    d.memoryTotalBytes = total / static_cast<std::uint64_t>(m_slots);
    d.memoryUsedBytes = used / static_cast<std::uint64_t>(m_slots);
    d.utilization = utilization;
    out.push_back(std::move(d));
  }
  return out;
}

std::string CpuProbe::describe() const {
  return std::to_string(m_slots) + " CPU slot(s) on " + std::to_string(m_cores) + " cores";
}

std::unique_ptr<DeviceProbe> chooseProbe(bool forceCpu, int cpuSlots, const std::string& nvmlLibrary) {
  if (forceCpu) {
    spdlog::info("devices: CPU slots (--force-cpu)");
    return std::make_unique<CpuProbe>(cpuSlots);
  }
  auto nvml = std::make_unique<NvmlProbe>(nvmlLibrary);
  if (nvml->available() && nvml->deviceCount() > 0) {
    spdlog::info("devices: {}", nvml->describe());
    return nvml;
  }
  spdlog::info("devices: CPU slots, because {}", nvml->reason());
  return std::make_unique<CpuProbe>(cpuSlots);
}

}  // namespace pflow::agent
