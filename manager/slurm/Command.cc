#include "manager/slurm/Command.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

extern char** environ;

namespace pflow::manager::slurm {
namespace {

struct Fd {
  int fd = -1;
  ~Fd() { if (fd >= 0) ::close(fd); }
};

}  // namespace

Result<CommandResult> runCommand(const std::vector<std::string>& argv, double timeoutSeconds) {
  if (argv.empty()) return invalidArgument("runCommand: empty command");
  int outPipe[2], errPipe[2];
  if (::pipe2(outPipe, O_CLOEXEC) != 0) return ioError(std::string("pipe: ") + std::strerror(errno));
  if (::pipe2(errPipe, O_CLOEXEC) != 0) {
    ::close(outPipe[0]);
    ::close(outPipe[1]);
    return ioError(std::string("pipe: ") + std::strerror(errno));
  }
  Fd outRead{outPipe[0]}, errRead{errPipe[0]};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, outPipe[1], 1);
  posix_spawn_file_actions_adddup2(&actions, errPipe[1], 2);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETPGROUP);
  std::vector<std::string> args = argv;
  std::vector<char*> cargs;
  for (auto& a : args) cargs.push_back(a.data());
  cargs.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, cargs[0], &actions, &attr, cargs.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  ::close(outPipe[1]);
  ::close(errPipe[1]);
  if (rc != 0) return notFound("cannot run " + argv[0] + ": " + std::strerror(rc));

  CommandResult result;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeoutSeconds);
  bool outOpen = true, errOpen = true, timedOut = false;
  char buf[65536];
  while (outOpen || errOpen) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      timedOut = true;
      break;
    }
    pollfd fds[2] = {{outOpen ? outRead.fd : -1, POLLIN, 0}, {errOpen ? errRead.fd : -1, POLLIN, 0}};
    const int n = ::poll(fds, 2, int(std::min<long long>(left, 1000)));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) break;
    for (int k = 0; k < 2; ++k) {
      if (!(fds[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t got = ::read(k == 0 ? outRead.fd : errRead.fd, buf, sizeof buf);
      if (got <= 0) {
        (k == 0 ? outOpen : errOpen) = false;
        continue;
      }
      std::string& dst = k == 0 ? result.out : result.err;
      const std::size_t cap = k == 0 ? (256u << 20) : (1u << 20);
      if (k == 0 && dst.size() + std::size_t(got) > cap) result.truncated = true;
      if (dst.size() < cap) dst.append(buf, std::min<std::size_t>(std::size_t(got), cap - dst.size()));
    }
  }
  int status = 0;
  if (timedOut) {
    ::kill(-pid, SIGKILL);
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    return Status(StatusCode::kDeadlineExceeded, argv[0] + " did not answer within " + std::to_string(int(timeoutSeconds)) + " s");
  }
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
  result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  return result;
}

}  // namespace pflow::manager::slurm
