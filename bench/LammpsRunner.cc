#include "bench/LammpsRunner.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <system_error>

namespace pflow::bench {
namespace fs = std::filesystem;

namespace {

constexpr const char* kDataFile = "bed.data";
constexpr const char* kInputFile = "in.lammps";
constexpr const char* kLogFile = "log.lammps";
constexpr const char* kOutputFile = "lammps.out";  // stdout and stderr of the command

// Shortest text that reads back as the same double.
std::string num(double v) {
  char buf[40];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// Quotes a word for /bin/sh.
std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

// Material constants shared by the pair style and the walls.
struct Contact {
  double tsujiInput;    // what `damping tsuji` is given
  double wallE;         // E passed to fix wall/gran so that it uses E* = E/(2(1-nu^2))
  double wallKt;        // explicit Mindlin k_t = 8 G* for a wall of the same material
  double rollStiffness; // rolling sds spring, N/m
  double rollDamping;   // rolling sds dashpot, N s/m
};

Contact contactFor(double e, double E, double nu, bool clipped, double meanRadius, double meanMass) {
  Contact c{};
  c.tsujiInput = lammpsTsujiInputFor(e, clipped);
  c.wallE = E / (1.0 + nu);
  const double g = E / (2.0 * (1.0 + nu));
  const double gStar = g / (2.0 * (2.0 - nu));  // same material on both sides
  c.wallKt = 8.0 * gStar;
  // Rolling spring: the Mindlin stiffness at an overlap of 1 % of R*, R* = R/2; critically damped over the
  // rolling inertia (2/5) m R^2 / R*^2. Only used when rollingFriction > 0 (a constant-torque limit then acts).
  const double rStar = 0.5 * meanRadius;
  c.rollStiffness = 8.0 * gStar * std::sqrt(rStar * 0.01 * rStar);
  c.rollDamping = 2.0 * std::sqrt(c.rollStiffness * 1.6 * meanMass);
  return c;
}

// The granular model words after `pair_coeff * *` or `fix ID group wall/gran granular`.
std::string modelWords(double E, double tsuji, double nu, const std::string& kt, double xGammaT, double mu,
                       double muRoll, const Contact& c, bool clipped) {
  std::string s = "hertz/material " + num(E) + " " + num(tsuji) + " " + num(nu) + " tangential mindlin " + kt + " " +
                  num(xGammaT) + " " + num(mu) + " damping tsuji";
  if (muRoll > 0) s += " rolling sds " + num(c.rollStiffness) + " " + num(c.rollDamping) + " " + num(muRoll);
  if (clipped) s += " limit_damping";
  return s;
}

std::string pairCoeff(double E, double nu, double xGammaT, double mu, double muRoll, const Contact& c, bool clipped) {
  return "pair_coeff * * " + modelWords(E, c.tsujiInput, nu, "NULL", xGammaT, mu, muRoll, c, clipped);
}

std::string wallFix(const std::string& id, const std::string& plane, double nu, double xGammaT, double mu,
                    double muRoll, const Contact& c, bool clipped) {
  return "fix " + id + " all wall/gran granular " +
         modelWords(c.wallE, c.tsujiInput, nu, num(c.wallKt), xGammaT, mu, muRoll, c, clipped) + " " + plane;
}

double sphereMass(double r, double rho) { return rho * 4.0 / 3.0 * std::numbers::pi * r * r * r; }

// A work directory: given (kept) or temporary (removed unless kept).
class WorkDir {
 public:
  static Result<WorkDir> open(const std::string& given, bool keep) {
    WorkDir w;
    std::error_code ec;
    if (!given.empty()) {
      fs::create_directories(given, ec);
      if (ec) return ioError("cannot create LAMMPS work directory " + given + ": " + ec.message());
      w.m_path = fs::absolute(given);
      w.m_remove = false;
      return w;
    }
    std::string tmpl = (fs::temp_directory_path() / "pflow-lammps-XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) return ioError("cannot create a temporary directory from " + tmpl);
    w.m_path = tmpl;
    w.m_remove = !keep;
    return w;
  }
  WorkDir(WorkDir&& o) noexcept : m_path(std::move(o.m_path)), m_remove(o.m_remove) { o.m_remove = false; }
  WorkDir& operator=(WorkDir&&) = delete;
  ~WorkDir() {
    if (m_remove) {
      std::error_code ec;
      fs::remove_all(m_path, ec);
    }
  }
  const fs::path& path() const { return m_path; }
  bool removed() const { return m_remove; }
  void keep() { m_remove = false; }  // keep the files, e.g. for diagnosis after a failure

 private:
  WorkDir() = default;
  fs::path m_path;
  bool m_remove = false;
};

Result<std::string> readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return ioError("cannot read " + p.string());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Status writeText(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
  out.close();
  if (!out) return ioError("cannot write " + p.string());
  return Status::ok();
}

// Lines of `text` that start with `prefix` (after leading blanks).
std::vector<std::string> linesStarting(const std::string& text, const std::string& prefix) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const auto b = line.find_first_not_of(" \t");
    if (b != std::string::npos && line.compare(b, prefix.size(), prefix) == 0) out.push_back(line.substr(b));
  }
  return out;
}

std::string lastLines(const std::string& text, int n) {
  std::size_t pos = text.size();
  for (int i = 0; i <= n && pos > 0; ++i) {
    pos = text.rfind('\n', pos - 1);
    if (pos == std::string::npos) return text;
  }
  return text.substr(pos + 1);
}

std::optional<std::string> findOnPath(const std::string& name) {
  if (name.find('/') != std::string::npos) {
    if (::access(name.c_str(), X_OK) == 0) return name;
    return std::nullopt;
  }
  const char* path = std::getenv("PATH");
  if (path == nullptr) return std::nullopt;
  std::istringstream in(path);
  std::string dir;
  while (std::getline(in, dir, ':')) {
    if (dir.empty()) dir = ".";
    const fs::path p = fs::path(dir) / name;
    std::error_code ec;
    if (fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0) return p.string();
  }
  return std::nullopt;
}

struct ScriptRun {
  std::string log;
  std::string command;
  std::string logPath;  // empty when the directory was removed
};

// Writes `script` (and whatever `prepare` writes) into a work directory, runs LAMMPS there and returns the log.
template <class Prepare>
Result<ScriptRun> runInDir(const std::string& script, const LammpsOptions& options, Prepare&& prepare) {
  if (options.ranks < 1) return invalidArgument("LAMMPS ranks must be >= 1, got " + std::to_string(options.ranks));
  const auto lmp = findOnPath(options.lmp);
  if (!lmp) return Status(StatusCode::kNotFound, "LAMMPS executable '" + options.lmp + "' not found on PATH");
  std::optional<std::string> mpirun;
  if (options.ranks > 1) {
    mpirun = findOnPath(options.mpirun);
    if (!mpirun) return Status(StatusCode::kNotFound, "MPI launcher '" + options.mpirun + "' not found on PATH");
  }
  auto dir = WorkDir::open(options.workDir, options.keepFiles);
  if (!dir) return dir.status();
  if (Status s = prepare(dir->path()); !s) return s;
  if (Status s = writeText(dir->path() / kInputFile, script); !s) return s;

  std::string cmd = "cd " + shellQuote(dir->path().string()) + " && OMP_NUM_THREADS=1 ";
  if (mpirun) {
    cmd += "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " + shellQuote(*mpirun);
    if (::geteuid() == 0) cmd += " --allow-run-as-root";
    if (!options.mpirunArgs.empty()) cmd += " " + options.mpirunArgs;
    cmd += " -np " + std::to_string(options.ranks) + " ";
  }
  cmd += shellQuote(*lmp) + " -nocite -in " + kInputFile + " -log " + kLogFile + " -screen none > " + kOutputFile +
         " 2>&1";

  std::fflush(nullptr);
  const int raw = std::system(cmd.c_str());
  const fs::path logPath = dir->path() / kLogFile;
  auto log = readText(logPath);
  const bool exited = raw != -1 && WIFEXITED(raw);
  const int code = exited ? WEXITSTATUS(raw) : -1;
  if (!exited || code != 0 || !log) {
    dir->keep();
    std::string msg = "LAMMPS failed: `" + cmd + "` " +
                      (exited ? "exited with status " + std::to_string(code) : std::string("did not exit normally")) +
                      "; log " + logPath.string();
    if (log) {
      for (const auto& e : linesStarting(*log, "ERROR")) msg += "\n  " + e;
    }
    if (auto out = readText(dir->path() / kOutputFile); out && !out->empty()) msg += "\n  output: " + lastLines(*out, 8);
    return Status(StatusCode::kInternal, msg);
  }
  ScriptRun run{std::move(*log), cmd, dir->removed() ? std::string() : logPath.string()};
  return run;
}

// The restitution of a Hertz contact with Tsuji damping. With the overlap x in units of L and time in units of T,
// chosen so that k_n T^2 L^(1/2) / m* = 1 and the approach speed is L/T, every impact becomes
// x'' = -x^(3/2) - alpha x^(1/4) x', x(0) = 0, x'(0) = 1, so e depends on alpha only. RK4 with step h; a clipped
// contact never pulls (the acceleration of the overlap stays <= 0).
double integrateTsujiImpact(double alpha, bool clipped, double h) {
  auto acc = [&](double x, double v) {
    if (x <= 0.0) return 0.0;
    const double f = -x * std::sqrt(x) - alpha * std::sqrt(std::sqrt(x)) * v;
    return (clipped && f > 0.0) ? 0.0 : f;
  };
  double x = 0.0, v = 1.0;
  for (int i = 0; i < 1000000; ++i) {
    const double k1x = v, k1v = acc(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = acc(x + h * k3x, v + h * k3v);
    x += h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
    v += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
    if (x <= 0.0) return -v;
  }
  return std::nan("");
}

}  // namespace

// --- restitution mapping ---------------------------------------------------------------------------------------

double tsujiAlpha(double e) {
  // The polynomial LAMMPS evaluates for `damping tsuji` (pair_granular.cpp, fix_wall_gran.cpp).
  return 1.2728 - 4.2783 * e + 11.087 * e * e - 22.348 * std::pow(e, 3) + 27.467 * std::pow(e, 4) -
         18.022 * std::pow(e, 5) + 4.8218 * std::pow(e, 6);
}

double hertzTsujiRestitution(double alpha, bool clipped) { return integrateTsujiImpact(alpha, clipped, 5e-4); }

double lammpsTsujiInputFor(double restitution, bool clipped) {
  if (!(restitution > 0.0 && restitution <= 1.0)) return std::nan("");
  auto realised = [&](double input) { return hertzTsujiRestitution(tsujiAlpha(input), clipped); };
  double lo = 0.0, hi = 1.0;  // realised() increases with the input; alpha(1) ~ 3e-4 gives e ~ 0.9997
  if (restitution < realised(lo)) return std::nan("");
  if (restitution >= realised(hi)) return 1.0;
  for (int i = 0; i < 40; ++i) {
    const double mid = 0.5 * (lo + hi);
    (realised(mid) < restitution ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// --- bed -> LAMMPS -------------------------------------------------------------------------------------------

Status validateBed(const LammpsBed& b) {
  const std::size_t n = b.position.size();
  if (n == 0) return invalidArgument("LAMMPS bed has no particles");
  if (b.radius.size() != n) return invalidArgument("LAMMPS bed: radius has " + std::to_string(b.radius.size()) +
                                                   " entries, position " + std::to_string(n));
  if (!b.velocity.empty() && b.velocity.size() != n) return invalidArgument("LAMMPS bed: velocity size mismatch");
  if (!b.angularVelocity.empty() && b.angularVelocity.size() != n)
    return invalidArgument("LAMMPS bed: angularVelocity size mismatch");
  if (!(b.density > 0) || !(b.youngsModulus > 0)) return invalidArgument("LAMMPS bed: density and E must be > 0");
  if (!(b.poissonRatio >= 0 && b.poissonRatio < 0.5)) return invalidArgument("LAMMPS bed: Poisson ratio not in [0, 0.5)");
  if (!(b.restitution > 0 && b.restitution <= 1)) return invalidArgument("LAMMPS bed: restitution not in (0, 1]");
  if (std::isnan(lammpsTsujiInputFor(b.restitution, b.clipNormalForce)))
    return invalidArgument("LAMMPS bed: restitution " + num(b.restitution) + " is below what damping tsuji can reach");
  if (!(b.friction >= 0) || !(b.rollingFriction >= 0) || !(b.tangentialDampingRatio >= 0))
    return invalidArgument("LAMMPS bed: friction coefficients and damping ratio must be >= 0");
  if (!(b.dt > 0) || !(b.skin > 0) || b.steps <= 0) return invalidArgument("LAMMPS bed: dt, skin and steps must be > 0");
  if (!(b.boxHi.x > b.boxLo.x && b.boxHi.y > b.boxLo.y)) return invalidArgument("LAMMPS bed: empty box");
  if (!isFinite(b.gravity)) return invalidArgument("LAMMPS bed: gravity not finite");
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d p = b.position[i];
    if (!(b.radius[i] > 0)) return invalidArgument("LAMMPS bed: radius[" + std::to_string(i) + "] must be > 0");
    if (!(p.x > b.boxLo.x && p.x < b.boxHi.x && p.y > b.boxLo.y && p.y < b.boxHi.y && p.z > b.boxLo.z) ||
        !std::isfinite(p.z))
      return invalidArgument("LAMMPS bed: particle " + std::to_string(i) + " centre outside the walls");
  }
  return Status::ok();
}

namespace {
// Top of the LAMMPS box: one largest diameter above the highest sphere, at least boxHi.z. The top is
// shrink-wrapped with this minimum (`fm`), so it grows if a sphere rises above it.
double boxTop(const LammpsBed& b) {
  double top = b.boxLo.z, rMax = 0;
  for (std::size_t i = 0; i < b.position.size(); ++i) {
    top = std::max(top, b.position[i].z + b.radius[i]);
    rMax = std::max(rMax, b.radius[i]);
  }
  return std::max(b.boxHi.z, top + 2.0 * rMax);
}

Contact contactForBed(const LammpsBed& b) {
  double rSum = 0;
  for (double r : b.radius) rSum += r;
  const double rMean = rSum / static_cast<double>(b.radius.size());
  return contactFor(b.restitution, b.youngsModulus, b.poissonRatio, b.clipNormalForce, rMean,
                    sphereMass(rMean, b.density));
}
}  // namespace

Status writeLammpsData(const LammpsBed& b, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return ioError("cannot write LAMMPS data file " + path);
  const std::size_t n = b.position.size();
  std::string text;
  text.reserve(200 * n + 512);
  auto put = [&](double v) {
    char buf[40];
    text.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
  };
  auto line = [&](std::size_t id, std::initializer_list<double> values) {
    text += std::to_string(id);
    for (double v : values) {
      text += ' ';
      put(v);
    }
    text += '\n';
  };
  text += "LAMMPS data file written by pflow_lammps_runner\n\n" + std::to_string(n) + " atoms\n1 atom types\n\n";
  text += num(b.boxLo.x) + " " + num(b.boxHi.x) + " xlo xhi\n" + num(b.boxLo.y) + " " + num(b.boxHi.y) + " ylo yhi\n" +
          num(b.boxLo.z) + " " + num(boxTop(b)) + " zlo zhi\n\n";
  text += "Atoms # sphere\n\n";  // atom-ID atom-type diameter density x y z
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d p = b.position[i];
    line(i + 1, {1.0, 2.0 * b.radius[i], b.density, p.x, p.y, p.z});
  }
  text += "\nVelocities\n\n";  // atom-ID vx vy vz wx wy wz
  const Vec3d zero{0, 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d v = b.velocity.empty() ? zero : b.velocity[i];
    const Vec3d w = b.angularVelocity.empty() ? zero : b.angularVelocity[i];
    line(i + 1, {v.x, v.y, v.z, w.x, w.y, w.z});
  }
  out << text;
  out.close();
  if (!out) return ioError("error writing LAMMPS data file " + path);
  return Status::ok();
}

std::string lammpsInputScript(const LammpsBed& b, const std::string& dataFile, bool newtonPair) {
  const Contact c = contactForBed(b);
  const double nu = b.poissonRatio, xg = b.tangentialDampingRatio, mu = b.friction, muR = b.rollingFriction;
  const bool clip = b.clipNormalForce;
  std::ostringstream s;
  s << "# pflow settled-bed benchmark: " << b.position.size() << " spheres, " << b.steps << " steps\n"
    << "# restitution " << num(b.restitution) << " -> damping tsuji input " << num(c.tsujiInput)
    << "; walls: E/(1+nu) and explicit k_t = 8G* (same material as the spheres)\n"
    << "units si\n"
    << "atom_style sphere\n"
    << "dimension 3\n"
    << "boundary f f fm\n"
    << "processors * * 1\n"  // split x and y only: gravity makes the bed non-uniform in z
    << "newton " << (newtonPair ? "on" : "off") << "\n"
    << "comm_modify vel yes\n"
    << "read_data " << dataFile << "\n"
    << "pair_style granular\n"
    << pairCoeff(b.youngsModulus, nu, xg, mu, muR, c, clip) << "\n"
    << wallFix("wall_x", "xplane " + num(b.boxLo.x) + " " + num(b.boxHi.x), nu, xg, mu, muR, c, clip) << "\n"
    << wallFix("wall_y", "yplane " + num(b.boxLo.y) + " " + num(b.boxHi.y), nu, xg, mu, muR, c, clip) << "\n"
    << wallFix("wall_z", "zplane " + num(b.boxLo.z) + " NULL", nu, xg, mu, muR, c, clip) << "\n";
  const double g = norm(b.gravity);
  if (g > 0) {
    const Vec3d d = (1.0 / g) * b.gravity;
    s << "fix gravity all gravity " << num(g) << " vector " << num(d.x) << " " << num(d.y) << " " << num(d.z) << "\n";
  }
  s << "fix integrate all nve/sphere\n"
    << "neighbor " << num(b.skin) << " bin\n"
    << "neigh_modify delay 0 every 1 check yes\n"
    << "timestep " << num(b.dt) << "\n"
    << "thermo_style custom step atoms ke\n"
    << "thermo 0\n"
    << "run " << b.steps << "\n";
  return s.str();
}

Result<std::string> runLammpsInput(const std::string& script, const LammpsOptions& options) {
  auto run = runInDir(script, options, [](const fs::path&) { return Status::ok(); });
  if (!run) return run.status();
  return std::move(run->log);
}

Result<LammpsResult> runLammps(const LammpsBed& bed, const LammpsOptions& options) {
  if (Status s = validateBed(bed); !s) return s;
  const std::string script = lammpsInputScript(bed, kDataFile, options.newtonPair);
  auto run = runInDir(script, options,
                      [&](const fs::path& dir) { return writeLammpsData(bed, (dir / kDataFile).string()); });
  if (!run) return run.status();

  LammpsResult r;
  r.ranks = options.ranks;
  r.command = run->command;
  r.logPath = run->logPath;
  r.tsujiInput = lammpsTsujiInputFor(bed.restitution, bed.clipNormalForce);
  const auto loop = linesStarting(run->log, "Loop time of ");
  int procs = 0;
  if (loop.empty() || std::sscanf(loop.back().c_str(), "Loop time of %lf on %d procs for %ld steps with %ld atoms",
                                  &r.loopSeconds, &procs, &r.steps, &r.atoms) != 4)
    return internalError("no 'Loop time' line in the LAMMPS log of `" + run->command + "`");
  if (procs != options.ranks)
    return internalError("LAMMPS ran on " + std::to_string(procs) + " procs, asked for " + std::to_string(options.ranks));
  if (r.atoms != static_cast<long>(bed.position.size()))
    return internalError("LAMMPS ended with " + std::to_string(r.atoms) + " atoms of " +
                         std::to_string(bed.position.size()) + " (atoms lost)");
  if (!(r.loopSeconds > 0)) return internalError("LAMMPS loop time is not positive");
  r.particleStepsPerSecond = static_cast<double>(r.atoms) * static_cast<double>(r.steps) / r.loopSeconds;
  if (auto l = linesStarting(run->log, "Neighbor list builds = "); !l.empty())
    std::sscanf(l.back().c_str(), "Neighbor list builds = %ld", &r.neighborBuilds);
  if (auto l = linesStarting(run->log, "Dangerous builds = "); !l.empty())
    std::sscanf(l.back().c_str(), "Dangerous builds = %ld", &r.dangerousBuilds);
  for (const char* section : {"Pair", "Neigh", "Comm", "Output", "Modify", "Other"}) {
    // "Pair    | 1.2 | 1.3 | 1.4 |   2.0 | 45.61": min, avg, max over ranks (the last line of that name)
    const auto l = linesStarting(run->log, std::string(section) + " ");
    double avg = 0;
    char name[16];
    if (!l.empty() && std::sscanf(l.back().c_str(), "%15s | %*f | %lf", name, &avg) == 2)
      r.sections.emplace_back(section, avg);
  }
  if (auto l = linesStarting(run->log, "LAMMPS ("); !l.empty()) {
    const auto& v = l.front();
    r.lammpsVersion = v.substr(8, v.rfind(')') == std::string::npos ? std::string::npos : v.rfind(')') - 8);
  }
  return r;
}

std::optional<std::string> findLammps() {
  if (const char* env = std::getenv("PFLOW_LAMMPS"); env != nullptr && *env != '\0') return findOnPath(env);
  return findOnPath("lmp");
}

// --- impact measurement --------------------------------------------------------------------------------------

Result<double> measureLammpsRestitution(double tsujiInput, const ImpactSpec& sp, const LammpsOptions& options) {
  if (!(tsujiInput >= 0 && tsujiInput <= 1)) return invalidArgument("tsuji input must be in [0, 1]");
  if (!(sp.radius > 0 && sp.density > 0 && sp.youngsModulus > 0 && sp.speed > 0 && sp.dt > 0))
    return invalidArgument("impact: radius, density, E, speed and dt must be > 0");
  const double r = sp.radius, nu = sp.poissonRatio, m = sphereMass(r, sp.density);
  Contact c = contactFor(1.0, sp.youngsModulus, nu, sp.clipNormalForce, r, m);
  c.tsujiInput = tsujiInput;
  // Elastic Hertz contact time bounds the damped one.
  const double eStar = sp.youngsModulus / (2.0 * (1.0 - nu * nu));
  const double mStar = sp.onWall ? m : 0.5 * m, rStar = sp.onWall ? r : 0.5 * r;
  const double tContact = 2.868 * std::pow(mStar * mStar / (rStar * eStar * eStar * sp.speed), 0.2);
  const double gap = 0.02 * r;
  const long steps = static_cast<long>(std::ceil((gap / sp.speed + 1.5 * tContact) / sp.dt)) + 10;

  std::ostringstream s;
  s << "units si\natom_style sphere\natom_modify map array\nboundary f f f\ncomm_modify vel yes\n"
    << "region box block " << num(-4 * r) << " " << num(4 * r) << " " << num(-4 * r) << " " << num(4 * r) << " "
    << num(sp.onWall ? 0.0 : -4 * r) << " " << num(8 * r) << "\n"
    << "create_box 1 box\n";
  if (sp.onWall) {
    s << "create_atoms 1 single 0 0 " << num(r + gap) << "\n";
  } else {
    s << "create_atoms 1 single 0 0 0\ncreate_atoms 1 single 0 0 " << num(2 * r + gap) << "\n";
  }
  s << "set atom * diameter " << num(2 * r) << " density " << num(sp.density) << "\n"
    << "group a1 id 1\n";
  if (sp.onWall) {
    s << "velocity a1 set 0 0 " << num(-sp.speed) << "\n";
  } else {
    s << "group a2 id 2\nvelocity a1 set 0 0 " << num(0.5 * sp.speed) << "\nvelocity a2 set 0 0 "
      << num(-0.5 * sp.speed) << "\n";
  }
  s << "pair_style granular\n" << pairCoeff(sp.youngsModulus, nu, 1.0, 0.5, 0.0, c, sp.clipNormalForce) << "\n";
  if (sp.onWall) s << wallFix("floor", "zplane 0 NULL", nu, 1.0, 0.5, 0.0, c, sp.clipNormalForce) << "\n";
  s << "fix integrate all nve/sphere\n"
    << "neighbor " << num(0.1 * r) << " bin\nneigh_modify delay 0 every 1 check yes\n"
    << "timestep " << num(sp.dt) << "\n"
    << "variable vz1 equal vz[1]\n";
  if (!sp.onWall) s << "variable vz2 equal vz[2]\n";
  s << "thermo 0\nrun " << steps << "\n";
  if (sp.onWall) s << "print \"PFLOW_VREL ${vz1}\"\n";
  else s << "variable vrel equal v_vz2-v_vz1\nprint \"PFLOW_VREL ${vrel}\"\n";

  auto log = runLammpsInput(s.str(), options);
  if (!log) return log.status();
  const auto lines = linesStarting(*log, "PFLOW_VREL ");
  double vOut = 0;
  if (lines.empty() || std::sscanf(lines.back().c_str(), "PFLOW_VREL %lf", &vOut) != 1)
    return internalError("no PFLOW_VREL line in the LAMMPS impact log");
  return vOut / sp.speed;
}

}  // namespace pflow::bench
