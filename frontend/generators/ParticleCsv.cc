// The particle CSV format (Generators.h, ParticleCsv): x,y,z,radius[,vx,vy,vz[,wx,wy,wz]] with a header naming the
// columns in any order; every bad line reported with its line and column, up to a limit.
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string_view>

#include "frontend/generators/Generators.h"

namespace pflow::frontend {

// ---- CSV ----------------------------------------------------------------------------------------------------------

namespace {

constexpr std::array<std::string_view, 10> kCsvColumns = {"x", "y", "z", "radius", "vx", "vy", "vz", "wx", "wy", "wz"};
constexpr std::size_t kMaxCsvErrors = 50;

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Fields of a line with the 1-based character column where each starts.
std::vector<std::pair<std::string_view, int>> splitFields(std::string_view line) {
  std::vector<std::pair<std::string_view, int>> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    const std::string_view raw = line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    const std::size_t lead = raw.size() - raw.substr(raw.find_first_not_of(" \t") == std::string_view::npos ? raw.size() : raw.find_first_not_of(" \t")).size();
    out.push_back({trim(raw), static_cast<int>(start + lead + 1)});
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

}  // namespace

Result<ParticleCsv> parseParticleCsv(std::string_view text, const std::string& name) {
  ErrorList e;
  ParticleCsv out;
  std::array<int, kCsvColumns.size()> column;  // column index of each known name, -1 when absent
  column.fill(-1);
  std::size_t nColumns = 0;
  bool haveHeader = false, haveV = false, haveW = false;
  int lineNo = 0;
  std::size_t pos = 0;
  while (pos <= text.size() && e.size() < kMaxCsvErrors) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++lineNo;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    if (trim(line).empty()) {
      if (end == text.size()) break;
      continue;
    }
    const auto fields = splitFields(line);
    if (!haveHeader) {
      haveHeader = true;
      nColumns = fields.size();
      for (std::size_t c = 0; c < fields.size(); ++c) {
        const auto [field, col] = fields[c];
        const auto it = std::find(kCsvColumns.begin(), kCsvColumns.end(), field);
        if (it == kCsvColumns.end()) {
          e.add(name, "unknown column '" + std::string(field) + "' (columns are x, y, z, radius, vx, vy, vz, wx, wy, wz)", lineNo, col);
        } else if (column[static_cast<std::size_t>(it - kCsvColumns.begin())] >= 0) {
          e.add(name, "column '" + std::string(field) + "' appears twice", lineNo, col);
        } else {
          column[static_cast<std::size_t>(it - kCsvColumns.begin())] = static_cast<int>(c);
        }
      }
      for (std::size_t k = 0; k < 4; ++k) {
        if (column[k] < 0) e.add(name, "missing column '" + std::string(kCsvColumns[k]) + "' (x, y, z and radius are required)", lineNo, 1);
      }
      for (std::size_t group = 4; group <= 7; group += 3) {
        const int present = (column[group] >= 0) + (column[group + 1] >= 0) + (column[group + 2] >= 0);
        if (present != 0 && present != 3) {
          const std::string names = std::string(kCsvColumns[group]) + ", " + std::string(kCsvColumns[group + 1]) + ", " + std::string(kCsvColumns[group + 2]);
          e.add(name, "columns " + names + " must be given together", lineNo, 1);
        }
        (group == 4 ? haveV : haveW) = present == 3;
      }
      if (!e.empty()) break;  // rows cannot be read without a good header
      if (haveV) out.velocity.emplace();
      if (haveW) out.angularVelocity.emplace();
      continue;
    }
    if (fields.size() != nColumns) {
      e.add(name, std::to_string(fields.size()) + " values; the header has " + std::to_string(nColumns) + " columns", lineNo, 1);
      continue;
    }
    std::array<double, kCsvColumns.size()> v{};
    bool ok = true;
    for (std::size_t k = 0; k < kCsvColumns.size(); ++k) {
      if (column[k] < 0) continue;
      const auto [field, col] = fields[static_cast<std::size_t>(column[k])];
      double x = 0;
      const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), x);
      if (field.empty() || ec != std::errc() || ptr != field.data() + field.size() || !std::isfinite(x)) {
        e.add(name, "column '" + std::string(kCsvColumns[k]) + "': '" + std::string(field) + "' is not a finite number", lineNo, col);
        ok = false;
        continue;
      }
      if (k == 3 && !(x > 0)) {
        e.add(name, "column 'radius': " + std::string(field) + " must be > 0", lineNo, col);
        ok = false;
      }
      v[k] = x;
    }
    if (!ok) continue;
    out.position.push_back({v[0], v[1], v[2]});
    out.radius.push_back(v[3]);
    if (haveV) out.velocity->push_back({v[4], v[5], v[6]});
    if (haveW) out.angularVelocity->push_back({v[7], v[8], v[9]});
  }
  if (!haveHeader && e.empty()) e.add(name, "no header line (expected column names such as 'x, y, z, radius')");
  if (e.size() >= kMaxCsvErrors) e.add(name, "too many errors; stopped reading");
  if (!e.empty()) return e.toStatus("particle CSV " + name);
  return out;
}

Result<ParticleCsv> readParticleCsv(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return ioError("cannot open particle CSV '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return ioError("cannot read particle CSV '" + path + "'");
  return parseParticleCsv(text.str(), path);
}


}  // namespace pflow::frontend
