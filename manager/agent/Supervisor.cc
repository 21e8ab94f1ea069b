#include "manager/agent/Supervisor.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <iterator>
#include <thread>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "common/Log.h"
#include <spdlog/fmt/fmt.h>

extern char** environ;

namespace pflow::agent {

std::string DeviceRef::toString() const { return node + ":" + deviceKindName(kind) + ":" + std::to_string(index); }

// --- the command line ------------------------------------------------------------------------------------------------
std::vector<std::string> workerCommand(const Lease& lease, const std::vector<DeviceRef>& rankDevices,
                                       const std::string& workerPath) {
  std::vector<std::string> args{workerPath, "--job-id", lease.jobId, "--model", lease.modelUri};
  if (!lease.managerAddress.empty()) {
    args.insert(args.end(), {"--manager", lease.managerAddress});
  }
  if (!lease.backendAddress.empty()) {
    args.insert(args.end(), {"--backend", lease.backendAddress});
    if (lease.attempt > 1) args.push_back("--resume");  // from the job's last checkpoint on the back-end
  }
  if (lease.attempt > 1) args.insert(args.end(), {"--attempt", std::to_string(lease.attempt)});
  std::string devices;
  for (const DeviceRef& d : rankDevices) {
    if (!devices.empty()) devices += ',';
    devices += d.toString();
  }
  args.insert(args.end(), {"--devices", devices});
  return args;
}

LaunchPlan planLaunch(const Lease& lease, const LaunchConfig& config, const std::string& localNode) {
  LaunchPlan plan;
  plan.jobId = lease.jobId;
  plan.logPath = config.workdir + "/" + lease.jobId + ".log";
  plan.env = {{"OMPI_ALLOW_RUN_AS_ROOT", "1"},
              {"OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"},
              {"CUDA_DEVICE_ORDER", "PCI_BUS_ID"},  // CUDA ordinals = NVML indices, which the agent reports
              {"PFLOW_JOB_ID", lease.jobId}};

  const bool multiNode = std::any_of(lease.devices.begin(), lease.devices.end(),
                                     [&](const DeviceRef& d) { return d.node != localNode; });
  auto hostOf = [&](const std::string& node) {
    const auto it = lease.nodeHosts.find(node);
    return it != lease.nodeHosts.end() && !it->second.empty() ? it->second : node;
  };

  // Hosts in order of first appearance; ranks grouped by host in that order.
  std::vector<std::pair<std::string, std::vector<DeviceRef>>> hosts;
  if (multiNode) {
    for (const DeviceRef& d : lease.devices) {
      const std::string host = hostOf(d.node);
      auto it = std::find_if(hosts.begin(), hosts.end(), [&](const auto& h) { return h.first == host; });
      if (it == hosts.end()) {
        hosts.push_back({host, {}});
        it = hosts.end() - 1;
      }
      it->second.push_back(d);
    }
    for (const auto& [host, devices] : hosts) {
      plan.rankDevices.insert(plan.rankDevices.end(), devices.begin(), devices.end());
      plan.hostfileText += host + " slots=" + std::to_string(devices.size()) + "\n";
    }
    plan.hostfilePath = config.workdir + "/" + lease.jobId + ".hosts";
  } else {
    plan.rankDevices = lease.devices;
  }

  std::vector<std::string> argv = config.launcherPrefix;
  if (!config.mpirun.empty()) {
    argv.insert(argv.end(), {config.mpirun, "-np", std::to_string(plan.rankDevices.size()), "--oversubscribe",
                             "--bind-to", "none", "--map-by", "slot"});
    if (multiNode) argv.insert(argv.end(), {"--hostfile", plan.hostfilePath});
    if (!config.rshAgent.empty()) argv.insert(argv.end(), {"--mca", "plm_rsh_agent", config.rshAgent});
    for (const auto& [name, value] : plan.env) {
      if (name.rfind("OMPI_", 0) != 0) argv.insert(argv.end(), {"-x", name});
    }
    for (const std::string& name : config.passEnv) {
      if (std::getenv(name.c_str())) argv.insert(argv.end(), {"-x", name});
    }
    argv.insert(argv.end(), config.extraMpirunArgs.begin(), config.extraMpirunArgs.end());
  }
  const auto worker = workerCommand(lease, plan.rankDevices, config.workerPath);
  argv.insert(argv.end(), worker.begin(), worker.end());
  argv.insert(argv.end(), config.transportArgs.begin(), config.transportArgs.end());
  plan.argv = std::move(argv);
  return plan;
}

// --- processes ---------------------------------------------------------------------------------------------------------
namespace {

// f(pid, state) for every process of session `sid` (from /proc).
template <class F>
void forSession(int sid, F&& f) {
  if (sid <= 1) return;
  DIR* proc = opendir("/proc");
  if (!proc) return;
  while (dirent* e = readdir(proc)) {
    char* end = nullptr;
    const long pid = std::strtol(e->d_name, &end, 10);
    if (pid <= 0 || *end != '\0') continue;
    std::ifstream stat("/proc/" + std::string(e->d_name) + "/stat");
    std::string text;
    std::getline(stat, text);
    const auto close = text.rfind(')');  // the command name may hold spaces and parentheses
    if (close == std::string::npos) continue;
    std::istringstream fields(text.substr(close + 1));
    char state = 0;
    long ppid = 0, pgrp = 0, session = 0;
    fields >> state >> ppid >> pgrp >> session;
    if (fields && session == sid) f(static_cast<pid_t>(pid), state);
  }
  closedir(proc);
}

// Live (not zombie) processes of session `sid`.
int liveInSession(int sid) {
  int n = 0;
  forSession(sid, [&](pid_t, char state) { n += state != 'Z' && state != 'X'; });
  return n;
}

// Whether process `pid` is alive and its command line names job `jobId` (a pid file is not trusted on its own: the
// pid may have been reused since).
bool runsJob(int pid, const std::string& jobId) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/cmdline", std::ios::binary);
  std::string cmd((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::string> args;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= cmd.size(); ++i)
    if (i == cmd.size() || cmd[i] == '\0') {
      args.push_back(cmd.substr(start, i - start));
      start = i + 1;
    }
  for (std::size_t i = 0; i + 1 < args.size(); ++i)
    if (args[i] == "--job-id" && args[i + 1] == jobId) return liveInSession(pid) > 0;
  return false;
}

}  // namespace

int signalSession(int sid, int sig) {
  int count = 0;
  forSession(sid, [&](pid_t pid, char) { count += ::kill(pid, sig) == 0; });
  return count;
}

std::string pidFilePath(const std::string& workdir, const std::string& jobId) {
  return (std::filesystem::path(workdir) / (jobId + ".pid")).string();
}

std::vector<WorkerExit> stopOrphans(const std::string& workdir, double graceSeconds) {
  std::vector<WorkerExit> out;
  std::error_code ec;
  if (workdir.empty() || !std::filesystem::is_directory(workdir, ec)) return out;
  for (const auto& entry : std::filesystem::directory_iterator(workdir, ec)) {
    if (entry.path().extension() != ".pid") continue;
    const std::string jobId = entry.path().stem().string();
    int pid = 0;
    std::ifstream(entry.path()) >> pid;
    WorkerExit x;
    x.jobId = jobId;
    x.pid = pid;
    x.signal = SIGKILL;
    x.exitCode = 128 + SIGKILL;
    if (pid > 1 && runsJob(pid, jobId)) {
      const auto start = std::chrono::steady_clock::now();
      signalSession(pid, SIGTERM);
      while (liveInSession(pid) > 0 &&
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < graceSeconds)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      if (liveInSession(pid) > 0) {
        signalSession(pid, SIGKILL);
        x.killed = true;
      }
      x.stopRequested = true;
      x.reason = "stopped when its agent restarted: the worker (pid " + std::to_string(pid) + ") outlived the agent that started it";
      spdlog::warn("job {}: {}", jobId, x.reason);
    } else {
      x.reason = "its worker (pid " + std::to_string(pid) + ") ended while its agent was down (exit code unknown)";
      spdlog::warn("job {}: {}", jobId, x.reason);
    }
    std::filesystem::remove(entry.path(), ec);
    out.push_back(std::move(x));
  }
  return out;
}

namespace {
std::string signalName(int sig) {
  const char* d = strsignal(sig);
  return "signal " + std::to_string(sig) + (d ? " (" + std::string(d) + ")" : "");
}

std::string quoteForLog(const std::vector<std::string>& argv) {
  std::string s;
  for (const auto& a : argv) {
    const bool plain = !a.empty() && a.find_first_of(" \t\"'\\$") == std::string::npos;
    if (!s.empty()) s += ' ';
    s += plain ? a : "'" + a + "'";
  }
  return s;
}

std::string nowText() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}
}  // namespace

Supervisor::Supervisor(ExitCallback onExit, double graceSeconds)
    : m_onExit(std::move(onExit)), m_grace(graceSeconds), m_reaper([this] { reaperLoop(); }) {}

Supervisor::~Supervisor() {
  stopAll(m_grace + 5);
  {
    std::lock_guard lock(m_mutex);
    m_quit = true;
  }
  m_cv.notify_all();
  m_reaper.join();
}

Result<int> Supervisor::start(const LaunchPlan& plan) {
  if (plan.argv.empty()) return invalidArgument("empty command for job " + plan.jobId);
  std::lock_guard lock(m_mutex);
  if (m_children.count(plan.jobId)) return alreadyExists("job " + plan.jobId + " already runs on this node");

  std::error_code ec;
  const auto dir = std::filesystem::path(plan.logPath).parent_path();
  if (!dir.empty()) std::filesystem::create_directories(dir, ec);
  if (ec) return ioError("cannot create " + dir.string() + ": " + ec.message());
  if (!plan.hostfilePath.empty()) {
    std::ofstream hosts(plan.hostfilePath, std::ios::trunc);
    hosts << plan.hostfileText;
    if (!hosts.flush()) return ioError("cannot write the hostfile " + plan.hostfilePath);
  }
  const int logFd = ::open(plan.logPath.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (logFd < 0) return ioError("cannot open " + plan.logPath + ": " + std::strerror(errno));
  const std::string header = "=== pflow-agent " + nowText() + " job " + plan.jobId + ": " + quoteForLog(plan.argv) + "\n";
  if (::write(logFd, header.data(), header.size()) < 0) {
    ::close(logFd);
    return ioError("cannot write " + plan.logPath + ": " + std::strerror(errno));
  }
  const long long offset = ::lseek(logFd, 0, SEEK_END);

  // Everything the child needs is prepared here: between spawn and exec only the C library runs.
  std::vector<std::string> envStrings;
  std::set<std::string> overridden;
  for (const auto& [name, value] : plan.env) {
    envStrings.push_back(name + "=" + value);
    overridden.insert(name);
  }
  for (char** e = environ; e && *e; ++e) {
    const std::string entry(*e);
    if (!overridden.count(entry.substr(0, entry.find('=')))) envStrings.push_back(entry);
  }
  std::vector<char*> envp, argv;
  for (auto& s : envStrings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> argStrings = plan.argv;
  for (auto& s : argStrings) argv.push_back(s.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, logFd, 1);
  posix_spawn_file_actions_adddup2(&actions, logFd, 2);
  posix_spawn_file_actions_addclosefrom_np(&actions, 3);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  // A new session (so SIGKILL can reach ranks that mpirun puts in process groups of their own), no blocked signals
  // and default dispositions (the agent blocks SIGINT/SIGTERM for its signal thread).
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSID | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &all);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, argv[0], &actions, &attr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) {
    const std::string msg = "cannot start " + plan.argv[0] + ": " + std::strerror(rc);
    const std::string line = "=== pflow-agent: " + msg + "\n";
    [[maybe_unused]] auto n = ::write(logFd, line.data(), line.size());
    ::close(logFd);
    return failedPrecondition(msg);
  }
  ::close(logFd);

  Child c;
  c.pid = pid;
  c.pidPath = pidFilePath(dir.string(), plan.jobId);
  {  // for an agent restarted while the worker runs (stopOrphans)
    std::ofstream pidFile(c.pidPath, std::ios::trunc);
    pidFile << pid << "\n";
    if (!pidFile.flush()) spdlog::warn("job {}: cannot write {}", plan.jobId, c.pidPath);
  }
  c.logPath = plan.logPath;
  c.logOffset = offset;
  c.started = std::chrono::steady_clock::now();
  m_children.emplace(plan.jobId, c);
  std::erase(m_stoppedEnded, plan.jobId);
  spdlog::info("job {}: started pid {}: {}", plan.jobId, pid, quoteForLog(plan.argv));
  return static_cast<int>(pid);
}

Status Supervisor::stop(const std::string& jobId) {
  {
    std::lock_guard lock(m_mutex);
    auto it = m_children.find(jobId);
    if (it == m_children.end()) {
      // A second stop that comes after the first one's exit was reaped is still harmless.
      if (std::find(m_stoppedEnded.begin(), m_stoppedEnded.end(), jobId) != m_stoppedEnded.end()) return Status::ok();
      return notFound("job " + jobId + " does not run on this node");
    }
    Child& c = it->second;
    if (c.stopRequested || c.exited) return Status::ok();
    c.stopRequested = true;
    c.killAt = std::chrono::steady_clock::now() +
               std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(m_grace));
    // The pid is still ours: only the reaper reaps it, under this lock.
    ::kill(-c.pid, SIGTERM);
    spdlog::info("job {}: SIGTERM to process group {} (SIGKILL in {} s)", jobId, c.pid, m_grace);
  }
  m_cv.notify_all();
  return Status::ok();
}

bool Supervisor::stopAll(double waitSeconds) {
  for (const std::string& id : running()) (void)stop(id);
  std::unique_lock lock(m_mutex);
  return m_exitedCv.wait_for(lock, std::chrono::duration<double>(waitSeconds), [this] { return m_children.empty(); });
}

bool Supervisor::isRunning(const std::string& jobId) const {
  std::lock_guard lock(m_mutex);
  return m_children.count(jobId) > 0;
}

std::vector<std::string> Supervisor::running() const {
  std::lock_guard lock(m_mutex);
  std::vector<std::string> ids;
  for (const auto& [id, c] : m_children) ids.push_back(id);
  return ids;
}

void Supervisor::reaperLoop() {
  std::unique_lock lock(m_mutex);
  while (true) {
    if (m_quit && m_children.empty()) return;
    std::vector<WorkerExit> exits;
    const auto now = std::chrono::steady_clock::now();
    for (auto it = m_children.begin(); it != m_children.end();) {
      Child& c = it->second;
      if (c.exited) {
        ++it;
        continue;
      }
      siginfo_t info{};
      // WNOWAIT leaves the zombie in place, so its pid (the session id) cannot be reused while the rest of the
      // session is killed.
      if (::waitid(P_PID, static_cast<id_t>(c.pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid != 0) {
        signalSession(c.pid, SIGKILL);  // leftovers (ranks, helpers) of a worker that is gone
        int status = 0;
        ::waitpid(c.pid, &status, 0);
        c.exited = true;
        std::error_code rm;
        std::filesystem::remove(c.pidPath, rm);
        WorkerExit x;
        x.jobId = it->first;
        x.pid = c.pid;
        x.stopRequested = c.stopRequested;
        x.killed = c.killed;
        x.seconds = std::chrono::duration<double>(now - c.started).count();
        std::string last = lastErrorLine(c.logPath, c.logOffset);
        if (WIFSIGNALED(status)) {
          x.signal = WTERMSIG(status);
          x.exitCode = 128 + x.signal;
        } else {
          x.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
        }
        if (x.stopRequested) {
          x.reason = c.killed ? fmt::format("stopped: SIGKILL after {:g} s grace", m_grace)
                              : "stopped: SIGTERM";
          if (x.signal != 0) x.reason += "; ended by " + signalName(x.signal);
        } else if (x.signal != 0) {
          x.reason = "killed by " + signalName(x.signal);
          if (!last.empty()) x.reason += "; last log line: " + last;
        } else if (x.exitCode != 0) {
          x.reason = last.empty() ? "exit code " + std::to_string(x.exitCode) + " (empty log)" : last;
        }
        exits.push_back(std::move(x));
        ++it;
        continue;
      }
      if (c.stopRequested && !c.killed && now >= c.killAt) {
        const int n = signalSession(c.pid, SIGKILL);
        c.killed = true;
        spdlog::warn("job {}: still running {} s after SIGTERM: SIGKILL to {} process(es) of session {}", it->first,
                     m_grace, n, c.pid);
      }
      ++it;
    }
    if (!exits.empty()) {
      // The callback runs before the job leaves the table, so a job is never "not running" without its exit
      // having been handed over.
      lock.unlock();
      for (const WorkerExit& x : exits) {
        spdlog::info("job {}: pid {} exited with code {} after {:.1f} s{}{}", x.jobId, x.pid, x.exitCode, x.seconds,
                     x.reason.empty() ? "" : ": ", x.reason);
        if (m_onExit) m_onExit(x);
      }
      lock.lock();
      for (const WorkerExit& x : exits) {
        m_children.erase(x.jobId);
        if (x.stopRequested) {
          m_stoppedEnded.push_back(x.jobId);
          if (m_stoppedEnded.size() > kStoppedMemory) m_stoppedEnded.pop_front();
        }
      }
      m_exitedCv.notify_all();
      continue;
    }
    m_cv.wait_for(lock, std::chrono::milliseconds(50));
  }
}

}  // namespace pflow::agent
