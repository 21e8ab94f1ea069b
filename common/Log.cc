#include "common/Log.h"

#include <chrono>

#include <spdlog/sinks/stdout_color_sinks.h>

namespace pflow::log {
void init(const std::string& role, const std::string& level) {
  auto logger = spdlog::stderr_color_mt(role);
  logger->set_pattern("[%H:%M:%S.%e] [" + role + "] [%^%l%$] %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(level));
}
std::string escaped(std::string_view text, std::size_t max) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (out.size() >= max) return out + "... (" + std::to_string(text.size()) + " bytes)";
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c <= 0x7e && c != '\\') {
      out += static_cast<char>(c);
    } else {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

std::string utf8Escaped(std::string_view text) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = byte(i);
    // The length of a well-formed sequence starting here (RFC 3629: no overlongs, no surrogates, at most U+10FFFF).
    std::size_t n = 0;
    if (c < 0x80) n = c == '\\' ? 0 : 1;
    else if (c >= 0xc2 && c <= 0xdf) n = 2;
    else if (c >= 0xe0 && c <= 0xef) n = 3;
    else if (c >= 0xf0 && c <= 0xf4) n = 4;
    bool ok = n > 0 && i + n <= text.size();
    for (std::size_t k = 1; ok && k < n; ++k) ok = (byte(i + k) & 0xc0) == 0x80;
    if (ok && n == 3) ok = !(c == 0xe0 && byte(i + 1) < 0xa0) && !(c == 0xed && byte(i + 1) >= 0xa0);
    if (ok && n == 4) ok = !(c == 0xf0 && byte(i + 1) < 0x90) && !(c == 0xf4 && byte(i + 1) >= 0x90);
    if (ok) {
      out.append(text.substr(i, n));
      i += n;
    } else {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
      ++i;
    }
  }
  return out;
}

bool RateLimit::allow(const std::string& key, std::uint64_t* leftOut) {
  const double now = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  std::lock_guard lock(m_mu);
  if (m_windows.size() >= 10000 && !m_windows.count(key))
    for (auto it = m_windows.begin(); it != m_windows.end();)  // forget clients whose window has passed
      it = now - it->second.start > m_seconds ? m_windows.erase(it) : std::next(it);
  if (m_windows.size() >= 10000 && !m_windows.count(key)) return false;
  Window& w = m_windows[key];
  if (now - w.start > m_seconds) {
    if (leftOut) *leftOut = w.leftOut;
    w = Window{now, 0, 0};
  } else if (leftOut) {
    *leftOut = 0;
  }
  if (w.count >= m_lines) {
    ++w.leftOut;
    return false;
  }
  ++w.count;
  return true;
}

bool isPrintable(std::string_view text) {
  for (char c : text)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) return false;
  return true;
}

}  // namespace pflow::log
