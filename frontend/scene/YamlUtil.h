// Small helpers for reading YAML with precise messages: locations, did-you-mean, strict number parsing.
#pragma once
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>

namespace pflow::frontend::detail {

struct Loc {
  int line = 0, column = 0;  // 1-based; 0 = unknown
};

Loc locOf(const YAML::Mark& m);
// A node's location; `fallback` for an undefined or null node (a null value's mark points past it).
Loc locOf(const YAML::Node& n, Loc fallback = {});

template <class Range>
std::string joinNames(const Range& names) {
  std::string out;
  for (const auto& n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

std::string lower(std::string_view s);

// Optimal string alignment distance (Levenshtein plus adjacent transpositions).
std::size_t editDistance(std::string_view a, std::string_view b);

// The closest candidate to `word` (case-insensitive), or "" when none is close enough to be a likely typo.
template <class Range>
std::string closest(std::string_view word, const Range& candidates) {
  const std::string w = lower(word);
  std::string best;
  std::size_t bestDistance = std::numeric_limits<std::size_t>::max();
  for (const auto& c : candidates) {
    const std::size_t d = editDistance(w, lower(c));
    if (d < bestDistance) {
      bestDistance = d;
      best = std::string(c);
    }
  }
  const std::size_t limit = std::max<std::size_t>(2, w.size() / 3);
  return bestDistance <= limit ? best : std::string();
}

// "unknown <what> '<word>'; did you mean '<closest>'? <listName>: a, b, c"
template <class Range>
std::string unknownName(std::string_view what, std::string_view word, const Range& candidates, std::string_view listName) {
  std::string msg = "unknown " + std::string(what) + " '" + std::string(word) + "'";
  const std::string guess = closest(word, candidates);
  if (!guess.empty()) msg += "; did you mean '" + guess + "'?";
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict, PR105329) on `" " + std::string` chains.
  msg.append(" ").append(listName).append(": ").append(joinNames(candidates));
  return msg;
}

// How a node looks, for "expected X, got <describe>" messages.
std::string describe(const YAML::Node& n);
bool isQuoted(const YAML::Node& n);
// A plain (unquoted) YAML number, including .nan and +-.inf; nullopt for anything else.
std::optional<double> parseDouble(const YAML::Node& n);
// An integer, also written as an integral real (`1e6`); nullopt otherwise.
std::optional<long long> parseInteger(const YAML::Node& n);

}  // namespace pflow::frontend::detail
