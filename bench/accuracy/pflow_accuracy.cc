// pflow-accuracy: the accuracy-speed study (docs/accuracy.md). Runs every reference problem over the time
// step (fraction of the Rayleigh time), precision, stiffness softening, neighbour skin and rebuild interval;
// writes DIR/study.csv (one row per run and quantity; rows of other executors are kept, so a CPU and a GPU
// run give one file) and DIR/stability.csv (per problem, executor, precision and softening: the largest
// stable dt fraction and how the next one failed).
#include "bench/accuracy/SphStudy.h"
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "bench/accuracy/Problems.h"
#include "compute/dem/AccuracyTable.h"
#include "common/Log.h"

namespace pflow::bench::accuracy {
namespace {

// study.csv is read and written with the format `pflow validate` reads (compute::AccuracyTable): one type,
// one header.
using Row = compute::AccuracyRow;

std::string num(double v) {
  if (!std::isfinite(v)) return "nan";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// The setting every other is compared with: the finest step in double at full stiffness, default skin,
// automatic rebuilds (Setting's defaults but the step).
constexpr double kReferenceDt = 0.05;
bool isReference(const std::string& precision, double dt, double softening, double skin, std::int64_t rebuild) {
  const Setting d;
  return precision == "double" && dt == kReferenceDt && softening == d.softening && skin == d.skinFraction &&
         rebuild == d.rebuildInterval;
}
std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) out.push_back(f);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

// The rows already in `path`; none when it is absent or does not parse (then it is written afresh).
std::vector<Row> readCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return {};
  std::stringstream text;
  text << in.rdbuf();
  auto table = compute::AccuracyTable::parse(text.str(), path.string());
  if (!table) {
    std::fprintf(stderr, "warning: %s is not kept: %s\n", path.c_str(), table.status().toString().c_str());
    return {};
  }
  return table.value().rows();
}

void writeCsv(const std::filesystem::path& path, const std::vector<Row>& rows) {
  std::ofstream out(path);
  out << compute::AccuracyTable::kColumns << "\n";
  for (const auto& r : rows)
    out << r.problem << ',' << r.quantity << ',' << r.reference << ',' << r.executor << ',' << r.precision << ','
        << num(r.dtFraction) << ',' << num(r.softening) << ',' << num(r.skinFraction) << ',' << r.rebuildInterval << ','
        << num(r.value) << ',' << num(r.error) << ',' << num(r.wallSecondsPerSimSecond) << ',' << r.steps << ','
        << r.status << "\n";
}

// Per problem, executor, precision and softening, over the dt sweep (default skin, automatic rebuilds): the
// largest dt fraction below which every run was ok, and the first that failed and how.
void writeStability(const std::filesystem::path& path, const std::vector<Row>& rows) {
  using Key = std::tuple<std::string, std::string, std::string, double>;
  std::map<Key, std::map<double, std::string>> runs;  // dt -> status of the run (its rows share it)
  for (const auto& r : rows)
    if (r.skinFraction == Setting{}.skinFraction && r.rebuildInterval == Setting{}.rebuildInterval)
      runs[{r.problem, r.executor, r.precision, r.softening}][r.dtFraction] = r.status;
  std::ofstream out(path);
  out << "problem,executor,precision,softening,largest_stable_dt_fraction,failed_dt_fraction,failure\n";
  for (const auto& [key, byDt] : runs) {
    if (byDt.size() < 2) continue;  // not a dt sweep
    double stable = std::nan(""), failed = std::nan("");
    std::string failure = "none in the sweep";
    for (const auto& [dt, status] : byDt) {
      if (status != "ok") {
        failed = dt;
        failure = status;
        break;
      }
      stable = dt;
    }
    const auto& [problem, executor, precision, softening] = key;
    out << problem << ',' << executor << ',' << precision << ',' << num(softening) << ',' << num(stable) << ','
        << num(failed) << ',' << failure << "\n";
  }
}

struct Options {
  compute::ExecutorKind executor = compute::ExecutorKind::kCpu;
  bool quick = false;
  std::string out = "docs/accuracy", only;
  int threads = 0;
};

class Study {
 public:
  explicit Study(const Options& o) : m_opt(o) {}

  // Runs one setting of a problem; returns false when the run failed (its rows are recorded either way).
  bool run(const Problem& p, Setting s) {
    s.executor = m_opt.executor;
    s.threads = m_opt.threads;
    const Outcome o = p.run(s);
    m_lastStatus = o.status;
    // The reference setting of a bulk problem: its packings' own values (noise.csv, the noise floor).
    if (isReference(precisionName(s.precision), s.dtFraction, s.softening, s.skinFraction, s.rebuildInterval))
      for (std::size_t i = 0; i < o.packings.size(); ++i)
        for (std::size_t k = 0; k < o.packings[i].size(); ++k)
          m_noise.push_back(p.name + ',' + o.quantities[i].name + ',' + executorName(s.executor) + ',' + std::to_string(k) +
                            ',' + num(o.packings[i][k]));
    std::string line;
    for (const auto& q : o.quantities) {
      Row r;
      r.problem = p.name, r.quantity = q.name, r.reference = num(q.reference), r.executor = executorName(s.executor);
      r.precision = precisionName(s.precision), r.dtFraction = s.dtFraction, r.softening = s.softening;
      r.skinFraction = s.skinFraction, r.rebuildInterval = s.rebuildInterval, r.value = q.value;
      r.wallSecondsPerSimSecond = o.wallPerSimSecond, r.steps = o.steps, r.status = o.status;
      r.error = std::fabs(q.value - q.reference) / std::fabs(q.reference);
      m_rows.push_back(r);
      line += " " + q.name + "=" + num(q.value);
    }
    std::fprintf(stderr, "%-26s %-6s dt %-5s E/%-4s skin %-4s rebuild %-5d %-19s %8.3g wall-s/sim-s %9lld steps%s%s%s\n",
                 p.name.c_str(), precisionName(s.precision), num(s.dtFraction).c_str(), num(s.softening).c_str(),
                 num(s.skinFraction).c_str(), s.rebuildInterval, o.status.c_str(), o.wallPerSimSecond,
                 (long long)o.steps, line.c_str(), o.detail.empty() ? "" : " | ", o.detail.c_str());
    return o.status == "ok";
  }

  // dt fractions in increasing order, stopping after two failures in a row (past the point of failure).
  // A failure that the finest step already has (a softened material's excessive overlap) is the setting's,
  // not the step's: it does not stop the sweep.
  void dtSweep(const Problem& p, Setting s, const std::vector<double>& dts) {
    int failures = 0;
    std::string atFinest;
    for (double dt : dts) {
      s.dtFraction = dt;
      const bool ok = run(p, s);
      const std::string status = m_lastStatus;
      if (dt == dts.front()) atFinest = status;
      failures = ok || status == atFinest ? 0 : failures + 1;
      if (failures >= 2) break;
    }
  }

  void problem(const Problem& p) {
    using compute::Precision;
    const std::vector<Precision> precisions = {Precision::kDouble, Precision::kFloat};
    const std::size_t first = m_rows.size();
    if (m_opt.quick) {
      // CI smoke: the finest and the default step, one past failure, float, one softened and one rebuild run.
      for (double dt : {0.01, 0.2, 5.0}) run(p, {.dtFraction = dt});
      run(p, {.precision = Precision::kFloat, .dtFraction = 0.2});
      run(p, {.dtFraction = 0.2, .softening = 100});
      run(p, {.dtFraction = 0.2, .rebuildInterval = 1000});
    } else if (!p.bulk) {
      const std::vector<double> dts = {0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0, 5.0};
      for (Precision prec : precisions)
        for (double soft : {1.0, 10.0, 100.0, 1000.0}) dtSweep(p, {.precision = prec, .softening = soft}, dts);
      for (double skin : {0.02, 0.05, 0.2, 0.5}) run(p, {.dtFraction = 0.2, .skinFraction = skin});
      for (int every : {1, 10, 100, 1000, 10000}) run(p, {.dtFraction = 0.2, .rebuildInterval = every});
    } else {
      const std::vector<double> dts = {kReferenceDt, 0.1, 0.2, 0.4, 0.7, 1.0, 1.4, 2.0};
      for (Precision prec : precisions) dtSweep(p, {.precision = prec}, dts);
      for (double soft : {10.0, 100.0, 1000.0})
        for (double dt : {0.1, 0.2, 0.4}) run(p, {.dtFraction = dt, .softening = soft});
      for (double skin : {0.02, 0.05, 0.2, 0.5}) run(p, {.dtFraction = 0.2, .skinFraction = skin});
      for (int every : {1, 10, 30, 100, 300}) run(p, {.dtFraction = 0.2, .rebuildInterval = every});
      // No closed form: the reference is the finest setting in double (dt 0.05, E/1, default skin, automatic
      // rebuilds). Each value is the mean over three random packings (Problems.cc, averaged).
      std::map<std::string, double> ref;
      for (std::size_t i = first; i < m_rows.size(); ++i) {
        const Row& r = m_rows[i];
        if (isReference(r.precision, r.dtFraction, r.softening, r.skinFraction, r.rebuildInterval)) ref[r.quantity] = r.value;
      }
      for (std::size_t i = first; i < m_rows.size(); ++i) {
        Row& r = m_rows[i];
        const double reference = ref.count(r.quantity) ? ref[r.quantity] : std::nan("");
        r.reference = num(reference);
        r.error = std::fabs(r.value - reference) / std::fabs(reference);
      }
    }
  }

  // Merges this run's rows into DIR/study.csv (rows of other executors, and of problems not run now, stay)
  // and rewrites DIR/stability.csv from the merged file.
  void write(const std::set<std::string>& ran) const {
    std::filesystem::create_directories(m_opt.out);
    const auto csv = std::filesystem::path(m_opt.out) / "study.csv";
    std::vector<Row> merged;
    const std::string exec = executorName(m_opt.executor);
    for (const auto& r : readCsv(csv))
      if (r.executor != exec || !ran.count(r.problem)) merged.push_back(r);
    merged.insert(merged.end(), m_rows.begin(), m_rows.end());
    writeCsv(csv, merged);
    writeStability(std::filesystem::path(m_opt.out) / "stability.csv", merged);
    // noise.csv: the bulk problems' packings at the reference setting, merged the same way.
    const auto noise = std::filesystem::path(m_opt.out) / "noise.csv";
    const std::string noiseHeader = "problem,quantity,executor,packing,value";
    std::vector<std::string> lines;
    {
      std::ifstream in(noise);
      std::string line;
      if (std::getline(in, line) && line == noiseHeader)
        while (std::getline(in, line)) {
          const auto f = split(line);
          if (f.size() == 5 && (f[2] != exec || !ran.count(f[0]))) lines.push_back(line);
        }
    }
    lines.insert(lines.end(), m_noise.begin(), m_noise.end());
    if (!lines.empty()) {
      std::ofstream out(noise);
      out << noiseHeader << "\n";
      for (const auto& l : lines) out << l << "\n";
    }
    std::fprintf(stderr, "wrote %s (%zu rows, %zu from this run) and stability.csv\n", csv.c_str(), merged.size(),
                 m_rows.size());
  }

 private:
  Options m_opt;
  std::vector<Row> m_rows;
  std::vector<std::string> m_noise;  // noise.csv lines
  std::string m_lastStatus;
};

}  // namespace
}  // namespace pflow::bench::accuracy

int main(int argc, char** argv) {
  using namespace pflow::bench::accuracy;
  CLI::App app{"pflow-accuracy: the accuracy-speed study of docs/accuracy.md (CSV to --out)"};
  Options o;
  std::string executor = "cpu";
  app.add_option("--executor", executor, "cpu | cuda")->check(CLI::IsMember({"cpu", "cuda"}));
  app.add_flag("--quick", o.quick, "a small subset (CI smoke): Chung & Ooi glass and aluminium, one restitution, the bouncing sphere");
  auto* outOpt = app.add_option("--out", o.out, "directory of study.csv, stability.csv and noise.csv (merged with what is there; "
                                                "default docs/accuracy, with --quick build/accuracy-quick)");
  app.add_option("--only", o.only, "run only the problems whose name starts with this (e.g. chung_ooi_1, settled_bed); "
                                   "sph: one sweep (resolution, mirror, dt, particles_at_1e-5)");
  app.add_option("--threads", o.threads, "OpenMP threads (0 = all)");
  std::string solver = "dem", precision = "double";
  app.add_option("--solver", solver, "dem: the DEM problems (docs/accuracy.md); sph: the dam break's convergence (docs/sph.md)")
      ->check(CLI::IsMember({"dem", "sph"}));
  app.add_option("--precision", precision, "sph: float | double")->check(CLI::IsMember({"float", "double"}));
  CLI11_PARSE(app, argc, argv);
  if (solver == "sph") {
    SphStudyOptions so;
    so.executor = executor == "cuda" ? pflow::compute::ExecutorKind::kCuda : pflow::compute::ExecutorKind::kCpu;
    so.precision = precision == "float" ? pflow::compute::Precision::kFloat : pflow::compute::Precision::kDouble;
    so.quick = o.quick;
    so.threads = o.threads;
    so.only = o.only;  // --only resolution | mirror | dt | particles_at_1e-5
    so.out = outOpt->count() ? o.out : (o.quick ? "build/sph-quick" : "docs/sph");
    spdlog::set_level(spdlog::level::warn);
    return runSphStudy(so);
  }
  if (o.quick && outOpt->count() == 0) o.out = "build/accuracy-quick";  // never mixed into the committed study
  o.executor = executor == "cuda" ? pflow::compute::ExecutorKind::kCuda : pflow::compute::ExecutorKind::kCpu;
  spdlog::set_level(spdlog::level::warn);  // the engine's per-run info lines would drown the table

  const std::set<std::string> quick = {"chung_ooi_1/glass", "chung_ooi_2/aluminium", "restitution/alumina_e0.6",
                                       "bouncing_sphere/e0.7"};
  Study study(o);
  std::set<std::string> ran;
  for (const auto& p : allProblems()) {
    if (o.quick && !quick.count(p.name)) continue;
    if (!o.only.empty() && p.name.rfind(o.only, 0) != 0) continue;
    study.problem(p);
    ran.insert(p.name);
  }
  if (ran.empty()) {
    std::fprintf(stderr, "no problem matches --only %s\n", o.only.c_str());
    return 2;
  }
  study.write(ran);
  return 0;
}
