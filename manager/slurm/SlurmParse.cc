#include "manager/slurm/SlurmParse.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <sstream>

namespace pflow::manager::slurm {
namespace {

bool toInt(const std::string& s, int& out) {
  if (s.empty()) return false;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

int intOr(const std::string& s, int fallback) {
  int v = 0;
  return toInt(s, v) ? v : fallback;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  for (char c : s) {
    if (c == '[' || c == '(') ++depth;
    if (c == ']' || c == ')') --depth;
    if (c == sep && depth == 0) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

}  // namespace

Record parseRecord(const std::string& line) {
  Record r;
  std::istringstream words(line);
  std::string w;
  while (words >> w) {
    const auto eq = w.find('=');
    // A key is a word of letters, digits, '_', '/', ':' before its first '='; anything else continues a value.
    bool isKey = eq != std::string::npos && eq > 0;
    for (std::size_t i = 0; isKey && i < eq; ++i) {
      const char c = w[i];
      isKey = std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/' || c == ':' || c == '.' || c == '-';
    }
    if (isKey) {
      r.emplace_back(w.substr(0, eq), w.substr(eq + 1));
    } else if (!r.empty()) {
      r.back().second += " " + w;
    }
  }
  return r;
}

std::vector<Record> parseRecords(const std::string& text) {
  std::vector<Record> out;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    Record r = parseRecord(line);
    if (!r.empty()) out.push_back(std::move(r));
  }
  return out;
}

std::string field(const Record& record, const std::string& key) {
  for (const auto& [k, v] : record)
    if (k == key) return v;
  return "";
}

Result<std::vector<int>> expandIdList(const std::string& list) {
  std::vector<int> out;
  for (const std::string& part : split(list, ',')) {
    const auto dash = part.find('-');
    int a = 0, b = 0;
    if (dash == std::string::npos) {
      if (!toInt(part, a)) return invalidArgument("id list '" + list + "': '" + part + "' is not a number");
      out.push_back(a);
      continue;
    }
    if (!toInt(part.substr(0, dash), a) || !toInt(part.substr(dash + 1), b) || b < a || b - a > 100000)
      return invalidArgument("id list '" + list + "': bad range '" + part + "'");
    for (int i = a; i <= b; ++i) out.push_back(i);
  }
  return out;
}

namespace {

// One name of a host list, its brackets expanded left to right ("rack[1-2]-n[01-02]": four names).
Status expandHostItem(const std::string& item, const std::string& list, std::vector<std::string>& out) {
  const auto open = item.find('[');
  if (open == std::string::npos) {
    if (item.find(']') != std::string::npos) return invalidArgument("host list '" + list + "': unbalanced ']'");
    out.push_back(item);
    return Status::ok();
  }
  const auto close = item.find(']', open);
  if (close == std::string::npos) return invalidArgument("host list '" + list + "': unbalanced '['");
  const std::string prefix = item.substr(0, open), suffix = item.substr(close + 1);
  for (const std::string& range : split(item.substr(open + 1, close - open - 1), ',')) {
    const auto dash = range.find('-');
    const std::string first = dash == std::string::npos ? range : range.substr(0, dash);
    const std::string last = dash == std::string::npos ? range : range.substr(dash + 1);
    int a = 0, b = 0;
    if (!toInt(first, a) || !toInt(last, b) || b < a || b - a > 100000)
      return invalidArgument("host list '" + list + "': bad range '" + range + "'");
    const std::size_t width = first.size();
    for (int i = a; i <= b; ++i) {
      std::string n = std::to_string(i);
      if (n.size() < width) n.insert(0, width - n.size(), '0');
      if (Status s = expandHostItem(prefix + n + suffix, list, out); !s) return s;
      if (out.size() > 1000000) return invalidArgument("host list '" + list + "': more than a million names");
    }
  }
  return Status::ok();
}

}  // namespace

Result<std::vector<std::string>> expandHostList(const std::string& list) {
  std::vector<std::string> out;
  if (list.empty() || list == "(null)") return out;
  for (const std::string& item : split(list, ','))
    if (Status s = expandHostItem(item, list, out); !s) return s;
  return out;
}

int gpuCount(const std::string& value) {
  int total = 0;
  for (const std::string& entry : split(value, ',')) {
    if (entry.rfind("gres/gpu", 0) == 0) {  // AllocTRES: gres/gpu=2 (and gres/gpu:h100=2, counted in gres/gpu too)
      const auto eq = entry.find('=');
      if (entry.compare(0, eq, "gres/gpu") == 0 && eq != std::string::npos) total += intOr(entry.substr(eq + 1), 0);
      continue;
    }
    if (entry.rfind("gpu", 0) != 0) continue;  // Gres: gpu[:type][:count][(S:...)]
    std::string e = entry.substr(0, entry.find('('));
    const auto colon = e.rfind(':');
    if (colon == std::string::npos) {  // "gpu": one
      total += e == "gpu" ? 1 : 0;
      continue;
    }
    int n = 0;
    total += toInt(e.substr(colon + 1), n) ? n : 1;  // "gpu:h100": one of that type
  }
  return total;
}

JobInfo jobFromRecord(const Record& r) {
  JobInfo j;
  j.id = field(r, "JobId");
  j.state = field(r, "JobState");
  j.reason = field(r, "Reason");
  j.comment = field(r, "Comment");
  j.name = field(r, "JobName");
  if (const std::string u = field(r, "UserId"); u.find('(') != std::string::npos)
    j.userId = std::atol(u.c_str() + u.find('(') + 1);
  j.stdOut = field(r, "StdOut");
  j.timeLimit = field(r, "TimeLimit");
  const std::string exit = field(r, "ExitCode");
  if (const auto colon = exit.find(':'); colon != std::string::npos) {
    j.exitCode = intOr(exit.substr(0, colon), 0);
    j.exitSignal = intOr(exit.substr(colon + 1), 0);
  }
  // The detailed record: "Nodes=LIST CPU_IDs=IDS Mem=M GRES=gpu(IDX:0-1)" once per group of nodes.
  std::vector<std::string> nodes;
  for (const auto& [k, v] : r) {
    if (k == "Nodes") {
      auto hosts = expandHostList(v);
      nodes = hosts ? hosts.value() : std::vector<std::string>{};
    } else if (k == "CPU_IDs" && !nodes.empty()) {
      if (auto ids = expandIdList(v))
        for (const std::string& n : nodes)
          for (int id : ids.value()) j.devices.push_back({n, id, DeviceKind::kCpu});
    } else if (k == "GRES" && !nodes.empty()) {
      // "gpu(IDX:0-1)", "gpu:2(IDX:0-1)", or one entry per type: "gpu:a100:1(IDX:0),gpu:h100:2(IDX:2-3)".
      bool gpus = false;
      for (const std::string& entry : split(v, ',')) {
        const auto idx = entry.find("IDX:");
        if (entry.rfind("gpu", 0) != 0 || idx == std::string::npos) continue;
        const auto end = entry.find(')', idx);
        auto ids = expandIdList(entry.substr(idx + 4, end == std::string::npos ? std::string::npos : end - idx - 4));
        if (!ids) continue;
        if (!gpus) {  // GPUs allocated: the job's devices on these nodes are its GPUs, not its CPUs
          std::erase_if(j.devices, [&](const DeviceKey& d) { return d.kind == DeviceKind::kCpu && std::count(nodes.begin(), nodes.end(), d.node); });
          gpus = true;
        }
        for (const std::string& n : nodes)
          for (int id : ids.value()) j.devices.push_back({n, id, DeviceKind::kGpu});
      }
    }
  }
  return j;
}

NodeInfo nodeFromRecord(const Record& r) {
  NodeInfo n;
  n.name = field(r, "NodeName");
  n.address = field(r, "NodeAddr");
  n.state = field(r, "State");
  n.reason = field(r, "Reason");
  n.cpus = intOr(field(r, "CPUTot"), 0);
  n.cpusAllocated = intOr(field(r, "CPUAlloc"), 0);
  const std::string gres = field(r, "Gres");
  n.gpus = gres == "(null)" ? 0 : gpuCount(gres);
  const std::string firstGres = gres.substr(0, gres.find_first_of("(,"));  // gpu:TYPE:N(S:0-1) -> TYPE
  if (const auto a = firstGres.find(':'), b = firstGres.rfind(':'); n.gpus > 0 && a != b) n.gpuType = firstGres.substr(a + 1, b - a - 1);
  n.gpusAllocated = gpuCount(field(r, "AllocTRES"));
  const std::string load = field(r, "CPULoad");
  n.cpuLoad = load.empty() || load == "N/A" ? 0 : std::atof(load.c_str());
  n.memoryBytes = std::uint64_t(std::max(0, intOr(field(r, "RealMemory"), 0))) * 1024 * 1024;
  for (const std::string& p : split(field(r, "Partitions"), ',')) n.partitions.push_back(p);
  return n;
}

}  // namespace pflow::manager::slurm
