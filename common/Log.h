// One logging facade over spdlog. Host code only: nothing under compute/ kernels logs.
#pragma once
#include <spdlog/spdlog.h>

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace pflow::log {
// Sets the process-wide pattern with a role prefix ("pflow-run", "rank 3", ...) and the level name.
void init(const std::string& role, const std::string& level = "info");

// Untrusted text (a request's name, an id, a file's line) as it may appear in a log line or an error message: bytes
// outside printable ASCII as \xNN, and at most `max` characters kept ("... (N bytes)" after them).
std::string escaped(std::string_view text, std::size_t max = 200);
// True when every byte is printable ASCII (0x20..0x7e).
bool isPrintable(std::string_view text);
// Text for a protobuf string field (which must be UTF-8) from untrusted input: valid UTF-8 sequences kept as they
// are (a scene's names may be in any script), every byte of an ill-formed one as \xNN, backslashes as \x5c.
std::string utf8Escaped(std::string_view text);

// At most `lines` log lines per `seconds` for each key (a client: its certificate's name or its address); the lines
// beyond are counted, and the first line of the next window says how many were left out. So one client cannot
// flood a service's log. Thread-safe; at most 10 000 keys are tracked (older windows are dropped first).
class RateLimit {
 public:
  explicit RateLimit(int lines = 20, double seconds = 10) : m_lines(lines), m_seconds(seconds) {}
  // Whether a line for `key` may be written now; `leftOut` gets how many lines of the key were left out before it
  // (to be said in that line), else 0.
  bool allow(const std::string& key, std::uint64_t* leftOut = nullptr);

 private:
  struct Window {
    double start = 0;
    int count = 0;
    std::uint64_t leftOut = 0;
  };
  int m_lines;
  double m_seconds;
  std::mutex m_mu;
  std::map<std::string, Window> m_windows;
};
}  // namespace pflow::log
