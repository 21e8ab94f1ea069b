// pflow-frontend: the frontend service (ValidateScene, BuildScene) over a model store folder.
#include <CLI/CLI.hpp>

#include <chrono>
#include <csignal>
#include <thread>
#include <filesystem>

#include "common/rpc/Health.h"
#include "common/Log.h"
#include "common/rpc/Rpc.h"
#include "frontend/service/FrontendService.h"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pflow-frontend: scene validation and model building (pflow.frontend.v1)"};
  std::string listen = "127.0.0.1:50052", models = "pflow-models", logLevel = "info";
  app.add_option("--listen", listen, "host:port to serve on")->capture_default_str();
  app.add_option("--models", models, "model store folder (workers must be able to read it)")->capture_default_str();
  app.add_option("--log-level", logLevel, "trace, debug, info, warn, error")->capture_default_str();
  pflow::rpc::TransportFlags transportFlags;
  transportFlags.add(app);
  CLI11_PARSE(app, argc, argv);
  pflow::log::init("frontend", logLevel);
  auto transport = transportFlags.resolve("frontend");
  if (!transport) {
    spdlog::error("{}", transport.status().message());
    return 2;
  }
  pflow::rpc::setDefaultTransport(transport.value());

  std::error_code ec;
  std::filesystem::create_directories(models, ec);
  if (ec) {
    spdlog::error("cannot create the model store '{}': {}", models, ec.message());
    return 2;
  }
  pflow::frontend::ModelStore store(models);
  pflow::frontend::FrontendServiceImpl service(store);
  auto server = pflow::rpc::ServerRunner::start(listen, {&service});
  if (!server) {
    spdlog::error("{}", server.status().message());
    return 2;
  }
  spdlog::info("serving pflow.frontend.v1 on {}, models in {}", server.value()->address(), store.root());
  pflow::rpc::HealthMonitor health(*server.value(), {pflow::frontend::v1::FrontendService::service_full_name()}, {});  // no dependency
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  spdlog::info("shutting down");
  server.value()->shutdown();
  return 0;
}
