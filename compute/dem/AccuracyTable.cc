#include "compute/dem/AccuracyTable.h"
#include "compute/core/Format.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <tuple>

#include "common/Log.h"

namespace pflow::compute {

// Generated at configure time from docs/accuracy/study.csv (compute/CMakeLists.txt): the file's text, or
// an empty string when the study has not produced it.
extern const char* const kAccuracyStudyCsv;

namespace {

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    std::string_view f = line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    while (!f.empty() && (f.front() == ' ' || f.front() == '\t')) f.remove_prefix(1);
    while (!f.empty() && (f.back() == ' ' || f.back() == '\t' || f.back() == '\r')) f.remove_suffix(1);
    out.push_back(f);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

std::string percent(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g %%", 100 * x);
  return buf;
}

}  // namespace

Result<AccuracyTable> AccuracyTable::parse(std::string_view csv, const std::string& source) {
  AccuracyTable table;
  ErrorList errors;
  const std::vector<std::string_view> columns = split(kColumns);
  std::size_t lineNo = 0, start = 0;
  bool header = false;
  while (start <= csv.size()) {
    std::size_t end = csv.find('\n', start);
    if (end == std::string_view::npos) end = csv.size();
    std::string_view line = csv.substr(start, end - start);
    start = end + 1;
    ++lineNo;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
    if (line.empty() || line.front() == '#') continue;
    const std::string where = source + ":" + std::to_string(lineNo);
    const auto f = split(line);
    if (!header) {
      if (f != columns)
        errors.add(where, "the header must be exactly `" + std::string(kColumns) + "`, got `" + std::string(line) + "`");
      header = true;
      if (!errors.empty()) break;
      continue;
    }
    if (f.size() != columns.size()) {
      errors.add(where, std::to_string(f.size()) + " fields, expected " + std::to_string(columns.size()));
      continue;
    }
    AccuracyRow r;
    auto number = [&](std::size_t k, double& out) {
      const std::string text(f[k]);
      char* stop = nullptr;
      errno = 0;
      out = std::strtod(text.c_str(), &stop);
      if (text.empty() || *stop != '\0' || errno == ERANGE)
        errors.add(where + " column " + std::string(columns[k]), "`" + text + "` is not a number");
    };
    auto integer = [&](std::size_t k, std::int64_t& out) {
      double v = 0;
      number(k, v);
      if (v != std::floor(v) || std::fabs(v) > 9e15)
        errors.add(where + " column " + std::string(columns[k]), "`" + std::string(f[k]) + "` is not an integer");
      else
        out = std::int64_t(v);
    };
    r.problem = f[0];
    r.quantity = f[1];
    r.reference = f[2];
    r.executor = f[3];
    r.precision = f[4];
    if (r.precision != "float" && r.precision != "double")
      errors.add(where + " column precision", "`" + r.precision + "` is not float or double");
    number(5, r.dtFraction);
    number(6, r.softening);
    number(7, r.skinFraction);
    integer(8, r.rebuildInterval);
    number(9, r.value);
    number(10, r.error);
    number(11, r.wallSecondsPerSimSecond);
    integer(12, r.steps);
    r.status = f[13];
    if (r.problem.empty() || r.quantity.empty() || r.executor.empty())
      errors.add(where, "problem, quantity and executor must not be empty");
    table.m_rows.push_back(std::move(r));
  }
  if (!errors.empty()) return errors.toStatus("accuracy table " + source);
  return table;
}

const AccuracyTable& AccuracyTable::builtIn() {
  static const AccuracyTable table = [] {
    auto t = parse(kAccuracyStudyCsv, "docs/accuracy/study.csv");
    if (!t) {
      spdlog::warn("the built-in accuracy table does not parse; accuracy targets get no proposal: {}", t.status().message());
      return AccuracyTable{};
    }
    return std::move(t).value();
  }();
  return table;
}

std::vector<std::string> AccuracyTable::quantities() const {
  std::set<std::string> q;
  for (const auto& r : m_rows) q.insert(r.quantity);
  return {q.begin(), q.end()};
}

Result<std::vector<AccuracyProposal>> AccuracyTable::propose(const std::string& quantity, double tolerance) const {
  const std::vector<std::string> known = quantities();
  if (std::find(known.begin(), known.end(), quantity) == known.end()) {
    std::string list;
    for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
    return invalidArgument("'" + quantity + "' is not a quantity of the accuracy study" +
                           (known.empty() ? std::string(" (its table is empty)") : "; known: " + list));
  }
  std::map<std::string, AccuracyProposal> best;
  for (AccuracyProposal& p : meeting(quantity, tolerance)) {
    auto it = best.find(p.executor);
    if (it == best.end() || p.cost < it->second.cost || (p.cost == it->second.cost && p.worstError < it->second.worstError))
      best[p.executor] = std::move(p);
  }
  std::vector<AccuracyProposal> out;
  for (auto& [executor, p] : best) out.push_back(std::move(p));
  return out;
}

bool AccuracyTable::meetsAt(const std::string& quantity, double tolerance, const std::string& executor,
                            const std::string& precision, double minDtFraction) const {
  for (const AccuracyProposal& p : meeting(quantity, tolerance))
    if (p.executor == executor && p.precision == precision && p.softening == 1 && p.rebuildInterval == 0 &&
        p.dtFraction >= minDtFraction * (1 - 1e-9))
      return true;
  return false;
}

std::vector<AccuracyProposal> AccuracyTable::meeting(const std::string& quantity, double tolerance) const {
  // Settings group -> problem -> (worst error, cost, every row ok).
  using Key = std::tuple<std::string, std::string, double, double, double, std::int64_t>;
  struct PerProblem {
    double error = 0, cost = 0;
    bool ok = true;
  };
  std::map<Key, std::map<std::string, PerProblem>> groups;
  std::map<std::string, std::set<std::string>> problemsOf;  // executor -> problems measuring the quantity
  for (const auto& r : m_rows) {
    if (r.quantity != quantity) continue;
    problemsOf[r.executor].insert(r.problem);
    PerProblem& p = groups[{r.executor, r.precision, r.dtFraction, r.softening, r.skinFraction, r.rebuildInterval}][r.problem];
    p.error = std::max(p.error, r.error);
    p.cost = std::max(p.cost, r.wallSecondsPerSimSecond);
    p.ok = p.ok && r.status == "ok" && r.error == r.error;  // NaN error: not ok
  }
  std::vector<AccuracyProposal> out;
  for (const auto& [key, problems] : groups) {
    const auto& [executor, precision, dtFraction, softening, skinFraction, rebuildInterval] = key;
    if (problems.size() != problemsOf[executor].size()) continue;  // not measured on every problem: no worst case
    AccuracyProposal p{executor, precision, dtFraction, softening, skinFraction, rebuildInterval, 0, 0, {}};
    bool meets = true;
    for (const auto& [problem, pp] : problems) {
      meets = meets && pp.ok && pp.error <= tolerance;
      p.worstError = std::max(p.worstError, pp.error);
      p.cost += pp.cost;
      p.problems.push_back(problem);
    }
    if (meets) out.push_back(std::move(p));
  }
  return out;
}

std::string AccuracyProposal::text() const {
  std::string list;
  for (const auto& p : problems) list += (list.empty() ? "" : ", ") + p;
  return executor + ": precision " + precision + ", dt_fraction " + format::num(dtFraction) + ", softening " + format::num(softening) +
         ", skin_fraction " + format::num(skinFraction) + ", rebuild_interval " + std::to_string(rebuildInterval) + " (worst error " +
         percent(worstError) + " over " + list + "; " + format::num(cost) + " wall s per simulated s)";
}

}  // namespace pflow::compute
