// pflow-web: the display role's web service (docs/viewer.md). Serves the page and, for each request, asks the manager
// and the back-end on behalf of the user whose token the request carries.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <csignal>
#include <thread>

#include "common/Log.h"
#include "common/rpc/Rpc.h"
#include "display/ViewerServer.h"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
  using namespace pflow;
  CLI::App app{"pflow-web: the web viewer's service (jobs, nodes, snapshot arrays, live events, the page)"};
  display::ViewerOptions o;
  std::string manager = "127.0.0.1:50051", backend = "127.0.0.1:50053", logLevel = "info";
  app.add_option("--listen", o.listen, "HOST:PORT to serve HTTP on (HTTPS with --tls-dir; plain HTTP on loopback only)")->capture_default_str();
  app.add_option("--manager", manager, "HOST:PORT of the manager")->capture_default_str();
  app.add_option("--backend", backend, "HOST:PORT of the back-end")->capture_default_str();
  app.add_option("--static", o.staticDir, "folder of the page's files");
  app.add_option("--threads", o.threads, "HTTP workers (each open event stream holds one)")->capture_default_str()->check(CLI::Range(2, 1024));
  app.add_option("--log-level", logLevel, "trace, debug, info, warn, error")->capture_default_str();
  rpc::TransportFlags transportFlags;
  transportFlags.add(app);
  CLI11_PARSE(app, argc, argv);
  log::init("pflow-web", logLevel);
  auto transport = transportFlags.resolve("web");
  if (!transport) {
    spdlog::error("{}", transport.status().message());
    return 1;
  }
  rpc::setDefaultTransport(transport.value());
  if (!transport->insecure && !transportFlags.tlsDir.empty()) {  // HTTPS with the same certificate
    o.certFile = transportFlags.tlsDir + "/web.crt";
    o.keyFile = transportFlags.tlsDir + "/web.key";
    if (rpc::isLoopbackHost(rpc::hostOf(o.listen))) o.certFile.clear(), o.keyFile.clear();  // loopback: plain HTTP
  }
  auto jobs = display::makeGrpcJobSource(manager);
  auto snapshots = display::makeGrpcSnapshotSource(backend);
  auto server = display::ViewerServer::start(o, *jobs, *snapshots);
  if (!server) {
    spdlog::error("{}", server.status().message());
    return 1;
  }
  spdlog::info("serving http{}://{}:{} (manager {}, back-end {}, page {})", o.certFile.empty() ? "" : "s", rpc::hostOf(o.listen),
               server.value()->port(), manager, backend, o.staticDir.empty() ? "(none)" : o.staticDir);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  spdlog::info("shutting down");
  server.value()->stop();
  return 0;
}
