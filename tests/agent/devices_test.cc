// Unit tests of the device probes: CPU slots from a fake /proc, NVML absent or unusable (no crash, empty, a reason).
#include "manager/agent/Devices.h"

#include <gtest/gtest.h>

#include "tests/agent/AgentTestUtil.h"

namespace pflow::agent {
namespace {

TEST(CpuProbe, SlotsShareMemoryAndReportLoad) {
  testing::TempDir proc;
  testing::writeFile(proc / "meminfo", "MemTotal:       16000000 kB\nMemFree:         1000000 kB\nMemAvailable:    12000000 kB\n");
  testing::writeFile(proc / "loadavg", "3.00 2.50 2.00 4/512 12345\n");
  CpuProbe probe(2, proc.path(), 12);
  const auto devices = probe.probe();
  ASSERT_EQ(devices.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(devices[i].kind, DeviceKind::kCpu);
    EXPECT_EQ(devices[i].index, i);
    EXPECT_EQ(devices[i].name, "CPU slot (12 cores)");
    EXPECT_EQ(devices[i].memoryTotalBytes, 16000000ull * 1024 / 2);
    EXPECT_EQ(devices[i].memoryUsedBytes, 4000000ull * 1024 / 2);
    EXPECT_DOUBLE_EQ(devices[i].utilization, 0.25);
    EXPECT_EQ(devices[i].temperatureC, 0);
  }
  EXPECT_EQ(probe.describe(), "2 CPU slot(s) on 12 cores");
}

TEST(CpuProbe, DefaultsAndRealProc) {
  CpuProbe probe;  // one slot, this machine
  const auto devices = probe.probe();
  ASSERT_EQ(devices.size(), 1u);
  EXPECT_GT(devices[0].memoryTotalBytes, 0u);
  EXPECT_LE(devices[0].memoryUsedBytes, devices[0].memoryTotalBytes);
  EXPECT_GE(devices[0].utilization, 0.0);
  EXPECT_LE(devices[0].utilization, 1.0);
  EXPECT_GE(probe.cores(), 1);
  EXPECT_NE(devices[0].name.find("cores)"), std::string::npos);
}

TEST(CpuProbe, MissingProcFilesGiveZeros) {
  testing::TempDir empty;
  CpuProbe probe(0, empty.path(), 4);  // 0 slots is taken as 1
  const auto devices = probe.probe();
  ASSERT_EQ(devices.size(), 1u);
  EXPECT_EQ(devices[0].memoryTotalBytes, 0u);
  EXPECT_EQ(devices[0].utilization, 0.0);
}

TEST(NvmlProbe, AbsentLibraryIsEmptyWithReason) {
  NvmlProbe probe("libnvidia-ml-does-not-exist.so.1");
  EXPECT_FALSE(probe.available());
  EXPECT_TRUE(probe.probe().empty());
  EXPECT_NE(probe.reason().find("cannot load libnvidia-ml-does-not-exist.so.1"), std::string::npos) << probe.reason();
  EXPECT_NE(probe.describe().find("NVML unavailable"), std::string::npos);
}

TEST(NvmlProbe, LibraryWithoutNvmlSymbolsIsRefused) {
  NvmlProbe probe("libc.so.6");  // loads, but has none of the functions
  EXPECT_FALSE(probe.available());
  EXPECT_TRUE(probe.probe().empty());
  EXPECT_NE(probe.reason().find("lacks nvmlInit_v2"), std::string::npos) << probe.reason();
}

TEST(NvmlProbe, RealDriverWhenPresent) {
  NvmlProbe probe;
  if (!probe.available()) GTEST_SKIP() << probe.reason();
  const auto gpus = probe.probe();
  EXPECT_EQ(static_cast<int>(gpus.size()), probe.deviceCount());
  for (const auto& g : gpus) {
    EXPECT_EQ(g.kind, DeviceKind::kGpu);
    EXPECT_FALSE(g.name.empty());
    EXPECT_GT(g.memoryTotalBytes, 0u);
  }
}

TEST(ChooseProbe, FallsBackToCpuSlots) {
  auto probe = chooseProbe(false, 3, "libnvidia-ml-does-not-exist.so.1");
  const auto devices = probe->probe();
  ASSERT_EQ(devices.size(), 3u);
  EXPECT_EQ(devices[2].kind, DeviceKind::kCpu);
  auto forced = chooseProbe(true, 1);
  EXPECT_EQ(forced->probe().at(0).kind, DeviceKind::kCpu);
}

}  // namespace
}  // namespace pflow::agent
