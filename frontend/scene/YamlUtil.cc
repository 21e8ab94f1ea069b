#include "frontend/scene/YamlUtil.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <vector>

namespace pflow::frontend::detail {

Loc locOf(const YAML::Mark& m) {
  if (m.is_null() || m.line < 0) return {};
  return {m.line + 1, m.column + 1};
}
Loc locOf(const YAML::Node& n, Loc fallback) {
  if (!n.IsDefined() || n.IsNull()) return fallback;  // a null value's mark points past it; the key is more useful
  try {
    const Loc l = locOf(n.Mark());
    return l.line > 0 ? l : fallback;
  } catch (const YAML::Exception&) {
    return fallback;
  }
}


std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// Optimal string alignment distance (Levenshtein plus adjacent transpositions).
std::size_t editDistance(std::string_view a, std::string_view b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}


std::string describe(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "nothing";
  if (n.IsScalar()) return (n.Tag() == "!" ? "the quoted string '" : "'") + n.Scalar() + "'";
  if (n.IsSequence()) return "a list of " + std::to_string(n.size()) + (n.size() == 1 ? " item" : " items");
  return "a mapping";
}

bool isQuoted(const YAML::Node& n) { return n.Tag() == "!" || n.Tag() == "tag:yaml.org,2002:str"; }

std::optional<double> parseDouble(const YAML::Node& n) {
  if (!n.IsScalar() || isQuoted(n)) return std::nullopt;
  std::string_view s = n.Scalar();
  if (s == ".nan" || s == ".NaN" || s == ".NAN") return std::numeric_limits<double>::quiet_NaN();
  bool negative = false;
  if (!s.empty() && (s[0] == '+' || s[0] == '-')) {
    negative = s[0] == '-';
    s.remove_prefix(1);
  }
  if (s == ".inf" || s == ".Inf" || s == ".INF") return negative ? -HUGE_VAL : HUGE_VAL;
  if (s.empty() || s[0] == '+' || s[0] == '-') return std::nullopt;
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
  return negative ? -v : v;
}

std::optional<long long> parseInteger(const YAML::Node& n) {
  if (!n.IsScalar() || isQuoted(n)) return std::nullopt;
  const std::string& s = n.Scalar();
  const char* b = s.data() + (!s.empty() && s[0] == '+' ? 1 : 0);
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(b, s.data() + s.size(), v);
  if (ec == std::errc() && ptr == s.data() + s.size()) return v;
  // Also accept integral numbers written as reals, e.g. `count: 1e6`.
  const auto d = parseDouble(n);
  if (d && std::isfinite(*d) && *d == std::floor(*d) && std::fabs(*d) < 9.0e15) return static_cast<long long>(*d);
  return std::nullopt;
}

}  // namespace pflow::frontend::detail
