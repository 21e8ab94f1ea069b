// pflow-agent: one per compute node. Reports its devices and heartbeats to the manager; starts, stops and reports
// compute workers for the manager's leases. See manager/agent/README.md.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <climits>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "common/Log.h"
#include "common/rpc/Health.h"
#include "common/rpc/Rpc.h"
#include "manager/agent/Agent.h"
#include "manager/agent/AgentService.h"

namespace {
std::string hostName() {
  char buf[HOST_NAME_MAX + 1] = {};
  if (gethostname(buf, sizeof buf - 1) != 0 || buf[0] == '\0') return "localhost";
  return buf;
}

std::string besideSelf(const std::string& name) {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? name : (self.parent_path() / name).string();
}
}  // namespace

int main(int argc, char** argv) {
  using namespace pflow;
  CLI::App app{"pflow-agent: the node agent (devices, heartbeats, compute workers)"};
  std::string node = hostName();
  std::string listen = "127.0.0.1:50061";
  std::string advertise;
  std::string manager;
  std::string workdir;
  std::string worker = besideSelf("pflow-worker");
  std::string mpirun = "mpirun";
  std::string rshAgent;
  std::string logLevel = "info";
  int cpuSlots = 1;
  bool forceCpu = false;
  bool printDevices = false;
  double heartbeat = 2;
  double grace = 10;
  app.add_option("--node", node, "this node's name (as the manager and leases call it)")->capture_default_str();
  app.add_option("--listen", listen, "HOST:PORT of the AgentService (port 0: any free port)")->capture_default_str();
  app.add_option("--advertise", advertise, "HOST:PORT the manager should call (default: the bound listen address; host name:port for a wildcard)");
  app.add_option("--manager", manager, "HOST:PORT of the manager's NodeRegistry (none: standalone, no heartbeats)");
  app.add_option("--workdir", workdir, "folder for worker logs and hostfiles (default: $TMPDIR/pflow-agent-NODE)");
  app.add_option("--worker", worker, "the compute worker program")->capture_default_str();
  app.add_option("--mpirun", mpirun, "the MPI launcher; '' runs the worker directly (one process, no MPI)")->capture_default_str();
  app.add_option("--rsh-agent", rshAgent, "Open MPI plm_rsh_agent for multi-node leases (default: Open MPI's ssh)");
  app.add_option("--cpu-slots", cpuSlots, "CPU slots to offer where there is no GPU")->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_flag("--force-cpu", forceCpu, "offer CPU slots even where NVML finds GPUs");
  app.add_option("--heartbeat-interval", heartbeat, "seconds between heartbeats (until the manager says otherwise)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--grace", grace, "seconds between SIGTERM and SIGKILL when stopping a worker")->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--print-devices", printDevices, "print the devices this node would report and exit");
  app.add_option("--log-level", logLevel, "trace, debug, info, warn, error")->capture_default_str();
  rpc::TransportFlags transportFlags;
  transportFlags.add(app);
  CLI11_PARSE(app, argc, argv);

  log::init("pflow-agent " + node, logLevel);
  if (workdir.empty()) {
    const char* tmp = std::getenv("TMPDIR");
    workdir = std::string(tmp && *tmp ? tmp : "/tmp") + "/pflow-agent-" + node;
  }
  std::error_code ec;
  std::filesystem::create_directories(workdir, ec);
  if (ec) {
    spdlog::error("cannot create the workdir {}: {}", workdir, ec.message());
    return 1;
  }
  workdir = std::filesystem::absolute(workdir).string();
  if (!transportFlags.tlsDir.empty()) transportFlags.tlsDir = std::filesystem::absolute(transportFlags.tlsDir).string();

  auto probe = agent::chooseProbe(forceCpu, cpuSlots);
  if (printDevices) {
    for (const agent::DeviceInfo& d : probe->probe()) {
      std::printf("%s:%s:%d  %s  memory %.2f/%.2f GiB  utilisation %.0f%%  temperature %.0f C\n", node.c_str(),
                  agent::deviceKindName(d.kind), d.index, d.name.c_str(), d.memoryUsedBytes / 1073741824.0,
                  d.memoryTotalBytes / 1073741824.0, d.utilization * 100, d.temperatureC);
    }
    return 0;
  }

  auto transport = transportFlags.resolve("node-" + node);
  if (!transport) {
    spdlog::error("{}", transport.status().message());
    return 1;
  }
  rpc::setDefaultTransport(transport.value());

  // SIGINT and SIGTERM are taken by sigwait below; every thread started from here on inherits the mask (workers get
  // a clean mask from the supervisor).
  sigset_t stopSignals;
  sigemptyset(&stopSignals);
  sigaddset(&stopSignals, SIGINT);
  sigaddset(&stopSignals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);

  agent::AgentOptions options;
  options.node = node;
  options.heartbeatIntervalSeconds = heartbeat;
  options.launch.workdir = workdir;
  options.launch.workerPath = worker;
  options.launch.mpirun = mpirun;
  options.launch.rshAgent = rshAgent;
  options.launch.graceSeconds = grace;
  options.launch.transportArgs = transportFlags.args();
  std::shared_ptr<agent::RegistryClient> registry;
  if (!manager.empty()) registry = std::make_shared<agent::GrpcRegistryClient>(manager);
  else spdlog::warn("no --manager: standalone (no heartbeats; exits are only logged)");

  agent::Agent theAgent(options, std::move(probe), registry);
  agent::AgentService service(theAgent);
  auto server = rpc::ServerRunner::start(listen, {&service});
  if (!server) {
    spdlog::error("{}", server.status().toString());
    return 1;
  }
  if (advertise.empty()) {
    // A wildcard listen address cannot be called back: advertise the host name with the bound port.
    const std::string host = rpc::hostOf(server.value()->address());
    const bool wildcard = host == "0.0.0.0" || host == "[::]" || host == "::" || host.empty();
    advertise = wildcard ? hostName() + ":" + std::to_string(server.value()->port()) : server.value()->address();
  }
  theAgent.setAdvertiseAddress(advertise);
  spdlog::info("node {}: listening on {} (advertised as {}), manager {}, workdir {}, worker {}", node,
               server.value()->address(), theAgent.options().advertiseAddress, manager.empty() ? "none" : manager,
               workdir, worker);
  theAgent.startHeartbeats();
  // Health (common/rpc/Health.h): the agent serves while the manager it reports to is up.
  std::vector<rpc::HealthMonitor::Dependency> healthDeps;
  if (!manager.empty()) healthDeps.push_back({"manager", manager});
  rpc::HealthMonitor health(*server.value(), {pflow::agent::v1::AgentService::service_full_name()}, healthDeps);

  int sig = 0;
  sigwait(&stopSignals, &sig);
  spdlog::info("{}: shutting down", strsignal(sig));
  theAgent.shutdown(5);  // no new jobs, workers stopped, exits delivered (for up to 5 s)
  server.value()->shutdown(2);
  return 0;
}
