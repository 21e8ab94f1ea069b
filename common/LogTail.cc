#include "common/LogTail.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

namespace pflow {

namespace {
std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

bool isRuler(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return c == '-' || c == '=' || c == '*' || c == ' '; });
}

bool mentionsError(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* word : {"error", "fatal", "abort", "exception", "failed", "what()"}) {
    if (s.find(word) != std::string::npos) return true;
  }
  return false;
}

std::string shorten(std::string s, std::size_t n = 400) {
  if (s.size() > n) s = s.substr(0, n) + "...";
  return s;
}
}  // namespace

std::string lastErrorLine(const std::string& logPath, long long fromOffset) {
  std::ifstream in(logPath, std::ios::binary);
  if (!in) return "";
  in.seekg(0, std::ios::end);
  const long long size = in.tellg();
  const long long start = std::max({0LL, fromOffset, size - 64 * 1024});
  if (start >= size) return "";
  std::string text(static_cast<std::size_t>(size - start), '\0');
  in.seekg(start);
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  // Open MPI frames its own notices between rulers of dashes ("Primary job terminated normally, but 1 process
  // returned a non-zero exit code. Per user-direction, the job has been aborted."): the worker's words come first.
  std::istringstream lines(text);
  std::string line, errorOutside, textOutside, noticed, errorInside, textInside;
  bool inBox = false;
  while (std::getline(lines, line)) {
    line = trim(line);
    if (line.size() >= 20 && isRuler(line)) {
      inBox = !inBox;
      continue;
    }
    if (line.empty() || isRuler(line)) continue;
    // srun's summary of its tasks ("srun: error: node: tasks 0-1: Exited with exit code 2", "... task 1: Killed") and
    // slurmstepd's "*** STEP ... CANCELLED ***" say less than the line before them (slurmstepd's execve error, the
    // worker's own): ranked with mpirun's notice; srun's bookkeeping ("Force Terminated", "_step_signal") not at all.
    const bool srun = line.rfind("srun:", 0) == 0;
    if (srun && (line.find("Force Terminated") != std::string::npos || line.find("_step_signal") != std::string::npos)) continue;
    if ((srun && (line.find("Exited with exit code") != std::string::npos || line.find(": Killed") != std::string::npos ||
                  line.find(": Terminated") != std::string::npos)) ||
        (line.rfind("slurmstepd", 0) == 0 && line.find("***") != std::string::npos)) {
      noticed = line;
      continue;
    }
    const bool launcher = srun;
    if (inBox || launcher) {
      textInside = line;
      if (line.rfind("mpirun noticed", 0) == 0) noticed = line;
      if (mentionsError(line)) errorInside = line;
    } else {
      textOutside = line;
      if (mentionsError(line)) errorOutside = line;
    }
  }
  for (const std::string* pick : {&errorOutside, &noticed, &textOutside, &errorInside, &textInside}) {
    if (!pick->empty()) return shorten(*pick);
  }
  return "";
}

}  // namespace pflow
