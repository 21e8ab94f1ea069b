// The scene's `slurm:` section (docs/scene-format.md, "Slurm"): partition, account and time limit of the job when the
// manager places jobs through Slurm. Checked here so that a typo is an error at submit time, not a refusal by
// sbatch after the scene was built: names of letters, digits, '_', '-' and '.', and a time limit in one of Slurm's
// formats.
#include <cctype>

#include "frontend/scene/Loader.h"

namespace pflow::frontend::detail {
namespace {

bool isSlurmName(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') return false;
  return true;
}

bool digits(const std::string& s, std::size_t maxLen = 6) {
  if (s.empty() || s.size() > maxLen) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

// MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS (Slurm's --time), or UNLIMITED / infinite.
bool isSlurmTime(const std::string& t) {
  if (t == "UNLIMITED" || t == "infinite") return true;
  std::string rest = t;
  bool days = false;
  if (const auto dash = t.find('-'); dash != std::string::npos) {
    if (!digits(t.substr(0, dash), 4)) return false;
    rest = t.substr(dash + 1);
    days = true;
  }
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const auto colon = rest.find(':', start);
    parts.push_back(rest.substr(start, colon == std::string::npos ? std::string::npos : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  if (parts.size() > 3) return false;
  for (const std::string& p : parts)
    if (!digits(p)) return false;
  return !days || !parts.empty();
}

}  // namespace

void Loader::parseSlurm(const Fields& top) {
  const Entry* e = top.find("slurm");
  if (!e) return;
  const auto f = mapping(e->value, "slurm", e->loc, Keys(kSlurmKeys));
  if (!f) return;
  for (auto [key, out] : {std::pair<const char*, std::string*>{"partition", &m_slurm.partition}, {"account", &m_slurm.account}}) {
    const Entry* k = f->find(key);
    if (!k || !get(*f, key, *out)) continue;
    if (!isSlurmName(*out))
      badValue(std::string("slurm.") + key, "'" + *out + "' is not a Slurm " + key + " name (letters, digits, '_', '-', '.'; at most 64)", k->loc);
  }
  if (const Entry* k = f->find("time_limit"); k && get(*f, "time_limit", m_slurm.timeLimit) && !isSlurmTime(m_slurm.timeLimit))
    badValue("slurm.time_limit",
             "'" + m_slurm.timeLimit + "' is not a Slurm time limit (minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS or UNLIMITED)",
             k->loc);
}

}  // namespace pflow::frontend::detail
