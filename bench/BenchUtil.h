// What the benchmark programs share for their results tables: a shell command's output (the CPU's name, the
// commit) and today's date.
#pragma once
#include <cstdio>
#include <ctime>
#include <string>

namespace pflow::bench {

// The command's standard output, trailing newlines and spaces removed ("" when it cannot run).
inline std::string shell(const char* cmd) {
  std::string out;
  if (FILE* p = popen(cmd, "r")) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

// YYYY-MM-DD, UTC.
inline std::string today() {
  std::time_t t = std::time(nullptr);
  char buf[16];
  std::strftime(buf, sizeof buf, "%Y-%m-%d", std::gmtime(&t));
  return buf;
}

}  // namespace pflow::bench
