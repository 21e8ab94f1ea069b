// pflow-manager: the job and device manager (ManagerService for users, NodeRegistry for agents and workers).
#include <CLI/CLI.hpp>
#include <pthread.h>
#include <unistd.h>

#include <fcntl.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <mutex>
#include <thread>

#include "common/Clock.h"
#include "common/Log.h"
#include "common/rpc/Health.h"
#include "common/rpc/Rpc.h"
#include "manager/GrpcAgentClient.h"
#include "manager/slurm/SlurmCommands.h"
#include "manager/GrpcFrontendClient.h"
#include "manager/JobStore.h"
#include "manager/Manager.h"
#include "manager/ManagerService.h"
#include "manager/Users.h"

namespace {

std::string hostname() {
  char buf[256] = {};
  return ::gethostname(buf, sizeof buf - 1) == 0 ? std::string(buf) : std::string("localhost");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace pflow;
  using namespace pflow::manager;

  CLI::App app{"pflow-manager: job and device manager of pflow"};
  std::string listen = "127.0.0.1:50051";
  std::string advertise;
  std::string dbPath = "pflow-manager.db";
  std::string frontendAddress;
  std::string backendAddress;
  std::string logLevel = "info";
  ManagerOptions options;
  double tickSeconds = 0.5;
  int threads = 8;
  app.add_option("--listen", listen, "HOST:PORT to serve ManagerService and NodeRegistry on")->capture_default_str();
  app.add_option("--advertise", advertise,
                 "HOST:PORT workers use to reach the manager (put in leases; default: --listen, with 0.0.0.0 or [::] "
                 "replaced by this host's name)");
  app.add_option("--db", dbPath, "SQLite job database (created if missing)")->capture_default_str();
  app.add_option("--frontend", frontendAddress, "HOST:PORT of the frontend (builds submitted scenes)");
  app.add_option("--backend", backendAddress, "HOST:PORT of the backend (put in leases: where workers send snapshots)");
  app.add_option("--particles-per-gpu", options.thresholds.particlesPerGpu,
                 "particles that keep one GPU busy: a job gets floor(particles / this) GPUs (at least 1)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--particles-per-cpu-slot", options.thresholds.particlesPerCpuSlot,
                 "particles that keep one CPU slot busy (nodes without GPUs)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--memory-headroom", options.thresholds.memoryHeadroom, "usable fraction of a device's memory")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 1.0));
  app.add_option("--heartbeat-timeout", options.heartbeatTimeoutSeconds, "seconds without a heartbeat before a node is lost")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--heartbeat-interval", options.heartbeatIntervalSeconds, "seconds between heartbeats (told to agents)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--missing-job-grace", options.missingJobGraceSeconds,
                 "seconds a started job may be missing from its agent's heartbeats before it is requeued")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--forget-lost-after", options.forgetLostNodeSeconds,
                 "seconds a lost node (holding no job) stays in `pflow nodes` before it is forgotten")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-attempts", options.maxAttempts,
                 "starts a job may have: a lost node, a vanished or killed worker requeues it until this many failed")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  app.add_option("--tick", tickSeconds, "seconds between lost-node checks and queue scans")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "worker threads for calls that reach agents or the frontend")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  int buildThreads = 2, maxPendingBuilds = 16;
  app.add_option("--build-threads", buildThreads, "submitted scenes built at once (each waits on the frontend)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--max-pending-builds", maxPendingBuilds,
                 "submissions building or waiting to be built at once; more are refused (RESOURCE_EXHAUSTED, try again)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  app.add_option("--log-level", logLevel, "trace, debug, info, warn, error")->capture_default_str();
  // Placement (docs/cluster.md): the agents, or Slurm.
  std::string placement = "agents", slurmBin, slurmWorkerTlsDir;
  slurm::SlurmSettings slurmSettings;
  double slurmGpuMemoryGiB = 0, slurmTimeout = 30;
  app.add_option("--placement", placement, "who places jobs: agents (pflow-agent on each node) or slurm (sbatch/scontrol/scancel)")
      ->capture_default_str()
      ->check(CLI::IsMember({"agents", "slurm"}));
  app.add_option("--slurm-workdir", slurmSettings.workdir,
                 "with --placement slurm: folder for batch scripts and workers' logs, at the same path on every node");
  app.add_option("--slurm-worker", slurmSettings.workerPath, "the worker program as the nodes find it")->capture_default_str();
  app.add_option("--slurm-partition", slurmSettings.partition, "partition for every job (and the only one whose nodes count)");
  app.add_option("--slurm-account", slurmSettings.account, "account for every job");
  app.add_option("--slurm-time-limit", slurmSettings.timeLimit, "time limit for every job, in Slurm's formats (e.g. 1-00:00:00)");
  app.add_option("--slurm-mpi", slurmSettings.mpi, "srun --mpi plugin for the workers")->capture_default_str();
  app.add_option("--slurm-cpus-per-task", slurmSettings.cpusPerTask, "CPUs (OpenMP threads) of each rank of a CPU job")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  app.add_option("--slurm-gpu-memory", slurmGpuMemoryGiB, "memory of one GPU in GiB (GRES does not say; 0: unknown, no memory minimum)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--slurm-poll", slurmSettings.pollSeconds, "seconds between reads of Slurm's jobs and nodes")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--slurm-bin", slurmBin, "folder of sbatch, scontrol and scancel (default: PATH)");
  app.add_option("--slurm-timeout", slurmTimeout, "seconds a Slurm command may take")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--slurm-worker-tls-dir", slurmWorkerTlsDir,
                 "TLS folder on the nodes with each node's certificate (node-NAME.crt/.key) for workers (default: --tls-dir)");
  rpc::TransportFlags transportFlags;
  transportFlags.add(app);
  std::string adminTokenFile, addUser, rotateUser;
  bool addAdmin = false;
  app.add_option("--admin-token-file", adminTokenFile,
                 "when the database has no users yet: make user 'admin' and write its token to this file (mode 0600)");
  app.add_option("--add-user", addUser, "add this user to --db, print its token and exit (with --admin: an admin)");
  app.add_flag("--admin", addAdmin, "with --add-user: the new user is an admin");
  app.add_option("--rotate-token", rotateUser, "give this user of --db a new token, print it and exit (the old one stops working)");
  CLI11_PARSE(app, argc, argv);

  log::init("pflow-manager", logLevel);
  if (options.heartbeatTimeoutSeconds < 2 * options.heartbeatIntervalSeconds)
    spdlog::warn("--heartbeat-timeout {} s is less than two heartbeat intervals ({} s): nodes will flap between lost and back",
                 options.heartbeatTimeoutSeconds, options.heartbeatIntervalSeconds);

  // SIGINT/SIGTERM are taken by sigwait below; block them before any thread starts so none of them gets them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto store = JobStore::open(dbPath);
  if (!store) {
    spdlog::error("{}", store.status().toString());
    return 1;
  }
  auto users = UserStore::open(dbPath);
  if (!users) {
    spdlog::error("{}", users.status().toString());
    return 1;
  }
  if (!addUser.empty() || !rotateUser.empty()) {  // local administration, then exit
    auto token = !addUser.empty() ? users.value()->add(addUser, addAdmin, SystemClock().now()) : users.value()->rotate(rotateUser);
    if (!token) {
      std::fprintf(stderr, "pflow-manager: %s\n", token.status().message().c_str());
      return 1;
    }
    std::printf("%s\n", token.value().c_str());
    return 0;
  }
  if (!adminTokenFile.empty()) {
    auto existing = users.value()->list();
    if (!existing) {
      spdlog::error("{}", existing.status().toString());
      return 1;
    }
    if (existing->empty()) {
      auto token = users.value()->add("admin", true, SystemClock().now());
      if (!token) {
        spdlog::error("making the first admin: {}", token.status().toString());
        return 1;
      }
      // A new file only (no link followed, no file of someone else's reused), 0600, written in full.
      const int fd = ::open(adminTokenFile.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
      const std::string line = token.value() + "\n";
      const bool written = fd >= 0 && ::write(fd, line.data(), line.size()) == ssize_t(line.size()) && ::fsync(fd) == 0;
      if (fd >= 0) ::close(fd);
      if (!written) {
        (void)users.value()->remove("admin");
        spdlog::error("cannot write the first admin's token to {} (it must not exist yet): {}", adminTokenFile, std::strerror(errno));
        return 1;
      }
      spdlog::info("no users yet: made user 'admin'; its token is in {}", adminTokenFile);
    }
  }
  auto transport = transportFlags.resolve("manager");
  if (!transport) {
    spdlog::error("{}", transport.status().message());
    return 1;
  }
  rpc::setDefaultTransport(transport.value());
  if (advertise.empty()) {
    const std::string host = rpc::hostOf(listen);
    advertise = (host == "0.0.0.0" || host == "[::]" || host.empty() ? hostname() : host) + listen.substr(host.size());
  }
  SystemClock clock;
  GrpcAgentClient agents;
  GrpcFrontendClient frontend(frontendAddress);
  options.backendAddress = backendAddress;
  std::unique_ptr<JobDataClient> jobData;
  if (!backendAddress.empty()) jobData = makeGrpcJobDataClient(backendAddress);

  options.managerAddress = advertise;
  std::unique_ptr<slurm::SlurmCommands> slurmClient;
  if (placement == "slurm") {
    if (slurmSettings.workdir.empty()) {
      spdlog::error("--placement slurm needs --slurm-workdir: a folder every node sees at the same path (scripts and logs)");
      return 1;
    }
    slurmSettings.workdir = std::filesystem::absolute(slurmSettings.workdir).lexically_normal().string();
    slurmSettings.gpuMemoryBytes = std::uint64_t(slurmGpuMemoryGiB * double(1ull << 30));
    if (slurmSettings.workerPath.find('/') != std::string::npos)  // a path, not a name for PATH: the same on every node
      slurmSettings.workerPath = std::filesystem::absolute(slurmSettings.workerPath).lexically_normal().string();
    slurmSettings.transportArgs = transportFlags.insecure ? std::vector<std::string>{"--insecure"}
                                                          : std::vector<std::string>{"--tls-dir", slurmWorkerTlsDir.empty() ? transportFlags.tlsDir : slurmWorkerTlsDir};
    options.slurm = slurmSettings;
    slurmClient = std::make_unique<slurm::SlurmCommands>(slurm::CommandsConfig{slurmBin, slurmTimeout});
    spdlog::info("manager: placement through Slurm (work folder {}, partition {}, worker {})", slurmSettings.workdir,
                 slurmSettings.partition.empty() ? "the cluster's default" : slurmSettings.partition, slurmSettings.workerPath);
  }
  auto manager = Manager::create(options, clock, *store.value(), agents, frontend, slurmClient.get());
  if (!manager) {
    spdlog::error("{}", manager.status().toString());
    return 1;
  }
  manager.value()->setJobDataClient(jobData.get());
  TaskPool pool(threads);
  TaskPool nodePool(std::max(2, threads / 2));  // heartbeats and exit reports: never behind user calls
  TaskPool builds(buildThreads);                 // submitted scenes, built while SubmitJob has answered BUILDING
  ManagerServiceImpl managerService(*manager.value(), *users.value(), pool, &builds, maxPendingBuilds);
  NodeRegistryImpl registry(*manager.value(), nodePool, !transport->insecure);
  auto server = rpc::ServerRunner::start(listen, {&managerService, &registry});
  if (!server) {
    spdlog::error("{}", server.status().toString());
    return 1;
  }
  if (advertise.size() >= 2 && advertise.substr(advertise.size() - 2) == ":0") {  // port 0: the bound one
    advertise = advertise.substr(0, advertise.size() - 1) + std::to_string(server.value()->port());
    manager.value()->setManagerAddress(advertise);
  }
  spdlog::info("listening on {} (advertised as {}); database {}; frontend {}; backend {}; {} particles per GPU, {} per CPU slot; "
               "heartbeat timeout {} s",
               server.value()->address(), advertise, dbPath, frontendAddress.empty() ? "(none)" : frontendAddress,
               backendAddress.empty() ? "(none)" : backendAddress, options.thresholds.particlesPerGpu,
               options.thresholds.particlesPerCpuSlot, options.heartbeatTimeoutSeconds);

  // Health (common/rpc/Health.h): both services serve while the frontend and the back-end it hands work to are up.
  std::vector<rpc::HealthMonitor::Dependency> healthDeps;
  if (!frontendAddress.empty()) healthDeps.push_back({"frontend", frontendAddress});
  if (!backendAddress.empty()) healthDeps.push_back({"back-end", backendAddress});
  rpc::HealthMonitor health(*server.value(), {v1::ManagerService::service_full_name(), v1::NodeRegistry::service_full_name()},
                            healthDeps);

  std::mutex tickMu;
  std::condition_variable tickCv;
  bool stopping = false;
  std::thread ticker([&] {
    std::unique_lock lock(tickMu);
    while (!tickCv.wait_for(lock, std::chrono::duration<double>(tickSeconds), [&] { return stopping; })) {
      lock.unlock();
      manager.value()->tick();
      lock.lock();
    }
  });

  int sig = 0;
  sigwait(&signals, &sig);
  spdlog::info("{}: shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");
  server.value()->shutdown(2.0);
  {
    std::lock_guard lock(tickMu);
    stopping = true;
  }
  tickCv.notify_all();
  ticker.join();
  spdlog::info("stopped");
  return 0;
}
