// Runs a program with arguments (no shell), collects its stdout and stderr, and kills it at a deadline. For the
// Slurm commands the manager calls.
#pragma once
#include <string>
#include <vector>

#include "common/Status.h"

namespace pflow::manager::slurm {

struct CommandResult {
  int exitCode = -1;    // the program's exit code; 128 + N when killed by signal N
  std::string out;      // stdout (at most 256 MiB kept)
  std::string err;      // stderr (at most 1 MiB kept)
  bool truncated = false;  // stdout was longer than it keeps: a reader must not take it as whole
};

// NOT_FOUND when the program cannot be started (not on PATH); DEADLINE_EXCEEDED when it ran past `timeoutSeconds`
// (it is killed). A non-zero exit is a result, not an error.
Result<CommandResult> runCommand(const std::vector<std::string>& argv, double timeoutSeconds);

}  // namespace pflow::manager::slurm
