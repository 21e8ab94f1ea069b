// pflow-backend: the SnapshotService (stores snapshots per job, computes grid fields, streams them back).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <fstream>
#include <thread>

#include "backend/SnapshotService.h"
#include "backend/SnapshotStore.h"
#include "common/Log.h"
#include "common/rpc/Health.h"
#include "common/rpc/Rpc.h"

namespace {
std::atomic<int> g_signal{0};
void onSignal(int sig) { g_signal = sig; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pflow-backend: snapshot storage, grid fields and the SnapshotService"};
  std::string listen = "127.0.0.1:50053";
  std::string dataDir = "pflow-data";
  double cellSize = 0;
  std::size_t maxOpen = 64;
  std::string portFile;
  std::string level = "info";
  app.add_option("--listen", listen, "HOST:PORT to serve on (port 0 picks a free one)")->capture_default_str();
  app.add_option("--data", dataDir, "data directory: one <job>.h5 + <job>.xmf per job")->capture_default_str();
  app.add_option("--grid-cell-size", cellSize, "grid cell size [m]; 0 = 4 x the largest particle radius of each snapshot")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-open-files", maxOpen, "job files kept open at once (the least recently used idle one is closed beyond it)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--port-file", portFile, "write the bound port to this file once serving");
  app.add_option("--log-level", level, "trace, debug, info, warn, error")->capture_default_str();
  std::string manager;
  app.add_option("--manager", manager, "HOST:PORT of the manager, which says which users may read which job (needed with TLS)");
  pflow::rpc::TransportFlags transportFlags;
  transportFlags.add(app);
  CLI11_PARSE(app, argc, argv);
  pflow::log::init("pflow-backend", level);
  auto transport = transportFlags.resolve("backend");
  if (!transport) {
    spdlog::error("{}", transport.status().message());
    return 1;
  }
  pflow::rpc::setDefaultTransport(transport.value());
  std::unique_ptr<pflow::backend::JobAccess> access;
  if (!manager.empty()) access = pflow::backend::makeManagerJobAccess(manager);
  else if (!transport->insecure) {
    spdlog::error("give --manager HOST:PORT: with TLS, users' reads are checked with the manager");
    return 1;
  }

  auto store = pflow::backend::SnapshotStore::open({dataDir, cellSize, maxOpen});
  if (!store) {
    spdlog::error("{}", store.status().toString());
    return 1;
  }
  pflow::backend::SnapshotService service(*store.value(), 2, access.get());
  auto server = pflow::rpc::ServerRunner::start(listen, {&service});
  if (!server) {
    spdlog::error("{}", server.status().toString());
    return 1;
  }
  spdlog::info("serving SnapshotService on {} (data {}, grid cell size {})", server.value()->address(), dataDir,
               cellSize > 0 ? std::to_string(cellSize) + " m" : std::string("4 x largest radius"));
  // Health (common/rpc/Health.h): reads are checked with the manager, so the service serves while it is up.
  std::vector<pflow::rpc::HealthMonitor::Dependency> healthDeps;
  if (!manager.empty()) healthDeps.push_back({"manager", manager});
  pflow::rpc::HealthMonitor health(*server.value(), {pflow::backend::v1::SnapshotService::service_full_name()}, healthDeps);
  if (!portFile.empty()) {
    std::ofstream(portFile + ".tmp") << server.value()->port() << "\n";
    std::rename((portFile + ".tmp").c_str(), portFile.c_str());
  }
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  while (g_signal == 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  spdlog::info("signal {}: shutting down", g_signal.load());
  server.value()->shutdown(5);
  return 0;
}
