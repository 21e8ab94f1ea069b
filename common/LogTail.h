// The line of a program's log that best explains its failure (the agent's workers under mpirun, the manager's
// Slurm jobs under srun). Pure file reading; no processes.
#pragma once
#include <string>

namespace pflow {

// The last line mentioning an error (error, fatal, abort, exception, failed, what()) outside the launcher's notices
// (Open MPI's, framed by rulers of dashes; srun's and slurmstepd's lines); else mpirun's "mpirun noticed that process
// rank R ... exited on signal N" line; else the last line with any text, outside notices first. "" for an empty log.
// Reads at most the last 64 KiB after byte `fromOffset`.
std::string lastErrorLine(const std::string& logPath, long long fromOffset = 0);

}  // namespace pflow
