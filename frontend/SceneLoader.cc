#include "frontend/SceneLoader.h"

#include <yaml-cpp/yaml.h>

#include "compute/core/Format.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <optional>
#include <random>
#include <span>
#include <sstream>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "compute/core/VectorMath.h"

namespace pflow::frontend {
namespace {

using compute::MaterialConfig;
using compute::MaterialPairConfig;
using compute::MeshConfig;
using compute::MeshMotion;
using compute::PlaneConfig;
using compute::RunConfig;
using Keys = std::span<const std::string_view>;

// Guards against scenes that would exhaust memory before the run even starts.
constexpr std::size_t kMaxParticles = std::size_t(1) << 30;
constexpr std::size_t kMaxBoxTriangles = 10'000'000;
constexpr double kDefaultSpacingFactor = 2.1;  // lattice spacing, in radii
constexpr double kDefaultJitter = 0.005;       // lattice jitter, in radii per axis

constexpr std::string_view kTopKeys[] = {"materials", "pairs", "particles", "geometry", "simulation", "output"};
constexpr std::string_view kMaterialKeys[] = {"name", "youngs_modulus", "poisson_ratio", "density", "restitution", "friction", "rolling_friction"};
constexpr std::string_view kPairKeys[] = {"materials", "restitution", "friction", "rolling_friction"};
constexpr std::string_view kParticleSetKeys[] = {"material", "list", "lattice"};
constexpr std::string_view kParticleKeys[] = {"position", "radius", "velocity", "angular_velocity"};
constexpr std::string_view kLatticeKeys[] = {"box", "radius", "spacing", "jitter", "velocity", "count"};
constexpr std::string_view kRegionKeys[] = {"min", "max"};
constexpr std::string_view kGeometryKeys[] = {"plane", "box", "mesh", "name", "material", "motion"};
constexpr std::string_view kPlaneKeys[] = {"point", "normal"};
constexpr std::string_view kBoxKeys[] = {"min", "max", "open", "resolution"};
constexpr std::string_view kMeshKeys[] = {"vertices", "triangles", "surfaces"};
constexpr std::string_view kMotionKeys[] = {"velocity", "angular_velocity", "axis", "axis_point", "start_time"};
constexpr std::string_view kSimulationKeys[] = {"gravity", "duration", "dt", "dt_fraction", "skin", "snapshot_interval",
                                                "domain", "precision", "history_slots", "wall_history_slots", "threads", "seed"};
constexpr std::string_view kOutputKeys[] = {"file"};
constexpr std::string_view kPrecisions[] = {"double", "float"};
// Box faces; the index is the face's surface number.
constexpr std::array<std::string_view, 6> kBoxFaces = {"bottom", "top", "left", "right", "front", "back"};

struct Loc {
  int line = 0, column = 0;  // 1-based; 0 = unknown
};

Loc locOf(const YAML::Mark& m) {
  if (m.is_null() || m.line < 0) return {};
  return {m.line + 1, m.column + 1};
}
Loc locOf(const YAML::Node& n, Loc fallback = {}) {
  if (!n.IsDefined() || n.IsNull()) return fallback;  // a null value's mark points past it; the key is more useful
  try {
    const Loc l = locOf(n.Mark());
    return l.line > 0 ? l : fallback;
  } catch (const YAML::Exception&) {
    return fallback;
  }
}

using format::at;
using format::num;
using format::vec;

template <class Range>
std::string joinNames(const Range& names) {
  std::string out;
  for (const auto& n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
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

template <class Range>
std::string unknownName(std::string_view what, std::string_view word, const Range& candidates, std::string_view listName) {
  std::string msg = "unknown " + std::string(what) + " '" + std::string(word) + "'";
  const std::string guess = closest(word, candidates);
  if (!guess.empty()) msg += "; did you mean '" + guess + "'?";
  msg += " " + std::string(listName) + ": " + joinNames(candidates);
  return msg;
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

std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Uniform in [-1, 1), the same on every standard library (std::uniform_real_distribution is not).
double symmetricUniform(std::mt19937_64& rng) { return 2.0 * static_cast<double>(rng() >> 11) * 0x1.0p-53 - 1.0; }

// Number of lattice sites along an edge of length `length`: centres at r, r + s, ... up to length - r.
std::size_t sitesAlong(double length, double radius, double spacing) {
  if (!(length >= 2 * radius)) return 0;
  return static_cast<std::size_t>(std::floor((length - 2 * radius) / spacing + 1e-9)) + 1;
}

// A box's inner faces as one mesh: each face a grid of nu x nv cells, 2 triangles per cell, normals into the box.
MeshConfig makeBoxMesh(const Vec3d& lo, const Vec3d& hi, const std::array<bool, 6>& open, double resolution) {
  const Vec3d d = hi - lo;
  const Vec3d ex{d.x, 0, 0}, ey{0, d.y, 0}, ez{0, 0, d.z};
  // origin, U, V with U x V pointing into the box; order = surface number.
  const std::array<std::array<Vec3d, 3>, 6> faces = {{
      {lo, ex, ey},                            // bottom (z = min), normal +z
      {Vec3d{lo.x, lo.y, hi.z}, ey, ex},       // top (z = max), normal -z
      {lo, ey, ez},                            // left (x = min), normal +x
      {Vec3d{hi.x, lo.y, lo.z}, ez, ey},       // right (x = max), normal -x
      {lo, ez, ex},                            // front (y = min), normal +y
      {Vec3d{lo.x, hi.y, lo.z}, ex, ez},       // back (y = max), normal -y
  }};
  MeshConfig mesh;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    if (open[f]) continue;
    const auto& [origin, u, v] = faces[f];
    // Cells of at most resolution / sqrt(2) per side keep every edge, diagonals included, within `resolution`.
    auto cells = [&](const Vec3d& edge) -> std::size_t {
      if (!(resolution > 0)) return 1;
      return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(norm(edge) * std::sqrt(2.0) / resolution - 1e-9)));
    };
    const std::size_t nu = cells(u), nv = cells(v);
    const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
    for (std::size_t j = 0; j <= nv; ++j) {
      for (std::size_t i = 0; i <= nu; ++i) {
        mesh.vertices.push_back(origin + (static_cast<double>(i) / nu) * u + (static_cast<double>(j) / nv) * v);
      }
    }
    auto vid = [&](std::size_t i, std::size_t j) { return static_cast<std::uint32_t>(base + j * (nu + 1) + i); };
    for (std::size_t j = 0; j < nv; ++j) {
      for (std::size_t i = 0; i < nu; ++i) {
        mesh.triangles.push_back({vid(i, j), vid(i + 1, j), vid(i + 1, j + 1)});
        mesh.triangles.push_back({vid(i, j), vid(i + 1, j + 1), vid(i, j + 1)});
        mesh.surface.push_back(static_cast<std::int32_t>(f));
        mesh.surface.push_back(static_cast<std::int32_t>(f));
      }
    }
  }
  return mesh;
}

class Loader {
 public:
  Result<LoadedScene> run(const std::string& yaml, const std::string& sourceName);

 private:
  struct Entry {
    std::string key;
    YAML::Node value;
    Loc keyLoc;
    Loc loc;  // of the value; the key's when the value is empty
  };
  struct Fields {
    std::string path;
    Loc loc;
    std::vector<Entry> entries;
    const Entry* find(std::string_view k) const {
      for (const Entry& e : entries) {
        if (e.key == k) return &e;
      }
      return nullptr;
    }
    std::string child(std::string_view k) const { return path.empty() ? std::string(k) : path + "." + std::string(k); }
  };
  struct ParticleSet {
    std::size_t first = 0, count = 0;
    std::string path;
    bool lattice = false;
    std::vector<Loc> entryLocs;  // explicit lists: one per particle
  };
  // RunConfig path prefix -> YAML path; keepSuffix appends what follows the prefix (e.g. `[3]`).
  struct PathMap {
    std::string rcPrefix, yamlPath;
    bool keepSuffix;
  };

  void error(const std::string& path, const std::string& message, Loc loc) { m_errors.add(path, message, loc.line, loc.column); }
  // An error that leaves the value unusable: validate() findings at or under this path are not repeated.
  void badValue(const std::string& path, const std::string& message, Loc loc) {
    error(path, message, loc);
    m_badPaths.push_back(path);
  }
  void missing(const Fields& f, std::string_view key, std::string_view hint = {}) {
    badValue(f.child(key), "required key '" + std::string(key) + "' is missing" + (hint.empty() ? "" : " (" + std::string(hint) + ")"), f.loc);
  }

  std::optional<Fields> mapping(const YAML::Node& n, const std::string& path, Loc loc, Keys allowed);
  bool isList(const YAML::Node& n, const std::string& path, Loc loc, std::string_view itemWhat);

  bool read(const YAML::Node& n, const std::string& path, Loc loc, double& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, int& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, std::uint64_t& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, std::string& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, Vec3d& out);
  template <class T>
  bool get(const Fields& f, std::string_view key, T& out, bool required = false) {
    const Entry* e = f.find(key);
    if (!e) {
      if (required) missing(f, key);
      return false;
    }
    return read(e->value, f.child(key), e->loc, out);
  }
  // `auto` or a number; nullopt for auto (and, after reporting it, for a type error).
  std::optional<double> autoOrNumber(const Entry& e, const std::string& path, std::string_view unit);
  int materialRef(const Fields& f, std::string_view key);
  int materialByName(const YAML::Node& n, const std::string& path, Loc loc);

  void parseMaterials(const Fields& top);
  void parsePairs(const Fields& top);
  void parseSimulation(const Fields& top);
  void parseParticles(const Fields& top);
  void parseParticleList(const YAML::Node& list, const std::string& path, Loc loc, int material, ParticleSet& set);
  void parseLattice(const YAML::Node& lattice, const std::string& path, Loc loc, int material, std::size_t setIndex);
  void parseGeometry(const Fields& top);
  bool parseRegion(const Fields& f, std::string_view key, Vec3d& lo, Vec3d& hi, bool required);
  void parseMotion(const Fields& g, MeshMotion& motion);
  void parseOutput(const Fields& top);

  void addParticle(const Vec3d& x, double r, const Vec3d& v, const Vec3d& w, int material);
  void appendValidation(const ErrorList& found);
  std::pair<std::string, Loc> locate(const std::string& rcPath, std::string& message) const;
  Loc markFor(std::string yamlPath) const;
  bool isBad(const std::string& yamlPath) const;

  ErrorList m_errors;
  RunConfig m_config;
  std::string m_outputFile;
  std::vector<std::string> m_badPaths;
  std::unordered_map<std::string, Loc> m_marks;  // YAML path -> where its value starts
  std::vector<PathMap> m_pathMaps;
  std::vector<ParticleSet> m_sets;
  std::map<std::string, int, std::less<>> m_materialIndex;
  std::vector<std::string> m_materialNames;
};

// ---- generic readers --------------------------------------------------------------------------------------------

std::optional<Loader::Fields> Loader::mapping(const YAML::Node& n, const std::string& path, Loc loc, Keys allowed) {
  if (!n.IsMap()) {
    badValue(path, "expected a mapping with keys " + joinNames(allowed) + ", got " + describe(n), locOf(n, loc));
    return std::nullopt;
  }
  Fields f;
  f.path = path;
  f.loc = locOf(n, loc);
  std::map<std::string, Loc> seen;
  for (auto it = n.begin(); it != n.end(); ++it) {
    const YAML::Node& keyNode = it->first;
    const Loc keyLoc = locOf(keyNode, f.loc);
    if (!keyNode.IsScalar()) {
      error(path, "keys must be plain names, got " + describe(keyNode), keyLoc);
      continue;
    }
    const std::string key = keyNode.Scalar();
    const std::string childPath = f.child(key);
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      error(childPath, unknownName("key", key, allowed, "Valid keys here"), keyLoc);
      continue;
    }
    if (auto [prev, inserted] = seen.emplace(key, keyLoc); !inserted) {
      error(childPath, "duplicate key '" + key + "' (first given at line " + std::to_string(prev->second.line) + "); this one is ignored", keyLoc);
      continue;
    }
    Entry e{key, it->second, keyLoc, locOf(it->second, keyLoc)};
    m_marks[childPath] = e.loc;
    f.entries.push_back(std::move(e));
  }
  return f;
}

bool Loader::isList(const YAML::Node& n, const std::string& path, Loc loc, std::string_view itemWhat) {
  if (n.IsSequence()) return true;
  badValue(path, "expected a list of " + std::string(itemWhat) + " (one '- ...' per item), got " + describe(n), locOf(n, loc));
  return false;
}

bool Loader::read(const YAML::Node& n, const std::string& path, Loc loc, double& out) {
  if (const auto v = parseDouble(n)) {
    out = *v;
    return true;
  }
  std::string msg = "expected a number, got " + describe(n);
  if (n.IsScalar() && isQuoted(n) && parseDouble(YAML::Node(n.Scalar()))) msg += " (write numbers without quotes)";
  badValue(path, msg, locOf(n, loc));
  return false;
}

bool Loader::read(const YAML::Node& n, const std::string& path, Loc loc, int& out) {
  const auto v = parseInteger(n);
  if (v && *v >= std::numeric_limits<int>::min() && *v <= std::numeric_limits<int>::max()) {
    out = static_cast<int>(*v);
    return true;
  }
  badValue(path, v ? std::to_string(*v) + " is too large" : "expected an integer, got " + describe(n), locOf(n, loc));
  return false;
}

bool Loader::read(const YAML::Node& n, const std::string& path, Loc loc, std::uint64_t& out) {
  if (n.IsScalar() && !isQuoted(n)) {
    const std::string& s = n.Scalar();
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    if (ec == std::errc() && ptr == s.data() + s.size()) return true;
  }
  badValue(path, "expected an integer in [0, 2^64), got " + describe(n), locOf(n, loc));
  return false;
}

bool Loader::read(const YAML::Node& n, const std::string& path, Loc loc, std::string& out) {
  if (n.IsScalar() && !n.Scalar().empty()) {
    out = n.Scalar();
    return true;
  }
  badValue(path, "expected a name, got " + describe(n), locOf(n, loc));
  return false;
}

bool Loader::read(const YAML::Node& n, const std::string& path, Loc loc, Vec3d& out) {
  if (!n.IsSequence() || n.size() != 3) {
    badValue(path, "expected a list of 3 numbers [x, y, z], got " + describe(n), locOf(n, loc));
    return false;
  }
  double c[3] = {0, 0, 0};
  bool ok = true;
  for (std::size_t k = 0; k < 3; ++k) {
    const YAML::Node item = n[k];
    if (const auto v = parseDouble(item)) {
      c[k] = *v;
    } else {
      ok = false;
      badValue(path, "component " + std::to_string(k) + " of [x, y, z]: expected a number, got " + describe(item), locOf(item, loc));
    }
  }
  if (ok) out = {c[0], c[1], c[2]};
  return ok;
}

std::optional<double> Loader::autoOrNumber(const Entry& e, const std::string& path, std::string_view unit) {
  if (e.value.IsScalar() && !isQuoted(e.value) && e.value.Scalar() == "auto") return std::nullopt;
  if (const auto v = parseDouble(e.value)) return *v;
  badValue(path, "expected a number (" + std::string(unit) + ") or 'auto', got " + describe(e.value), e.loc);
  return std::nullopt;
}

int Loader::materialByName(const YAML::Node& n, const std::string& path, Loc loc) {
  std::string name;
  if (!read(n, path, loc, name)) return -1;
  if (const auto it = m_materialIndex.find(name); it != m_materialIndex.end()) return it->second;
  if (m_materialNames.empty()) {
    badValue(path, "unknown material '" + name + "': no materials are defined (see 'materials')", locOf(n, loc));
  } else {
    badValue(path, unknownName("material", name, m_materialNames, "Materials"), locOf(n, loc));
  }
  return -1;
}

// A `material: name` reference; optional when the scene defines exactly one material.
int Loader::materialRef(const Fields& f, std::string_view key) {
  if (const Entry* e = f.find(key)) return materialByName(e->value, f.child(key), e->loc);
  if (m_materialNames.size() == 1) return 0;
  if (m_materialNames.empty()) {
    badValue(f.child(key), "required key '" + std::string(key) + "' is missing (and no materials are defined)", f.loc);
  } else {
    missing(f, key, "one of: " + joinNames(m_materialNames));
  }
  return -1;
}

// ---- sections ---------------------------------------------------------------------------------------------------

void Loader::parseMaterials(const Fields& top) {
  const Entry* e = top.find("materials");
  if (!e) {
    missing(top, "materials", "a list with at least one material");
    return;
  }
  if (!isList(e->value, "materials", e->loc, "materials")) return;
  std::size_t i = 0;
  for (const YAML::Node& item : e->value) {
    const std::string path = at("materials", i++);
    m_marks[path] = locOf(item, e->loc);
    MaterialConfig m;
    if (const auto f = mapping(item, path, e->loc, kMaterialKeys)) {
      get(*f, "name", m.name, true);
      get(*f, "youngs_modulus", m.youngsModulus, true);
      get(*f, "poisson_ratio", m.poissonRatio, true);
      get(*f, "density", m.density, true);
      get(*f, "restitution", m.restitution, true);
      get(*f, "friction", m.friction, true);
      get(*f, "rolling_friction", m.rollingFriction);
    }
    const int index = static_cast<int>(m_config.materials.size());
    if (!m.name.empty() && m_materialIndex.emplace(m.name, index).second) m_materialNames.push_back(m.name);
    m_config.materials.push_back(std::move(m));
  }
}

void Loader::parsePairs(const Fields& top) {
  const Entry* e = top.find("pairs");
  if (!e || !isList(e->value, "pairs", e->loc, "material pair overrides")) return;
  std::size_t i = 0;
  for (const YAML::Node& item : e->value) {
    const std::string path = at("pairs", i++);
    m_marks[path] = locOf(item, e->loc);
    MaterialPairConfig pair;
    if (const auto f = mapping(item, path, e->loc, kPairKeys)) {
      if (const Entry* names = f->find("materials")) {
        const std::string np = f->child("materials");
        if (!names->value.IsSequence() || names->value.size() != 2) {
          badValue(np, "expected a list of 2 material names [a, b], got " + describe(names->value), names->loc);
        } else {
          for (std::size_t k = 0; k < 2; ++k) {
            const YAML::Node item2 = names->value[k];
            const std::string ip = at(np, k);
            m_marks[ip] = locOf(item2, names->loc);
            const int idx = materialByName(item2, ip, names->loc);
            (k == 0 ? pair.a : pair.b) = idx;
          }
        }
      } else {
        missing(*f, "materials", "the two material names [a, b]");
      }
      double v = 0;
      if (get(*f, "restitution", v)) pair.restitution = v;
      if (get(*f, "friction", v)) pair.friction = v;
      if (get(*f, "rolling_friction", v)) pair.rollingFriction = v;
    }
    m_config.pairs.push_back(pair);
  }
}

void Loader::parseSimulation(const Fields& top) {
  const Entry* e = top.find("simulation");
  if (!e) {
    missing(top, "simulation", "at least simulation.duration");
    return;
  }
  const auto f = mapping(e->value, "simulation", e->loc, kSimulationKeys);
  if (!f) return;
  compute::SimulationSettings& s = m_config.sim;
  get(*f, "gravity", s.gravity);
  get(*f, "duration", s.duration, true);
  if (const Entry* dt = f->find("dt")) s.dt = autoOrNumber(*dt, "simulation.dt", "s");
  get(*f, "dt_fraction", s.dtFraction);
  if (const Entry* skin = f->find("skin")) {
    const auto v = autoOrNumber(*skin, "simulation.skin", "m");
    s.skin = v ? *v : -1.0;
  }
  get(*f, "snapshot_interval", s.snapshotInterval);
  compute::Aabb domain;
  if (parseRegion(*f, "domain", domain.lo, domain.hi, false)) s.domain = domain;
  if (const Entry* p = f->find("precision")) {
    std::string name;
    if (read(p->value, "simulation.precision", p->loc, name)) {
      if (name == "double") {
        s.precision = compute::Precision::kDouble;
      } else if (name == "float") {
        s.precision = compute::Precision::kFloat;
      } else {
        badValue("simulation.precision", unknownName("precision", name, kPrecisions, "Choices"), p->loc);
      }
    }
  }
  get(*f, "history_slots", s.historySlots);
  get(*f, "wall_history_slots", s.wallHistorySlots);
  get(*f, "threads", s.threads);
  get(*f, "seed", s.seed);
}

// `key: {min: [..], max: [..]}`; checks min < max per axis. True when both corners were read and are ordered.
bool Loader::parseRegion(const Fields& parent, std::string_view key, Vec3d& lo, Vec3d& hi, bool required) {
  const Entry* e = parent.find(key);
  if (!e) {
    if (required) missing(parent, key, "{min: [x, y, z], max: [x, y, z]}");
    return false;
  }
  const std::string path = parent.child(key);
  const auto f = mapping(e->value, path, e->loc, kRegionKeys);
  if (!f) return false;
  const bool haveLo = get(*f, "min", lo, true);
  const bool haveHi = get(*f, "max", hi, true);
  return haveLo && haveHi;
}

void Loader::addParticle(const Vec3d& x, double r, const Vec3d& v, const Vec3d& w, int material) {
  compute::ParticleInit& p = m_config.particles;
  const std::size_t i = p.position.size();
  p.position.push_back(x);
  p.radius.push_back(r);
  p.material.push_back(material);
  // Velocity arrays stay empty (= all zero) until some particle moves; then they hold one entry per particle.
  auto append = [i](std::vector<Vec3d>& values, const Vec3d& value) {
    if (values.empty() && value.x == 0 && value.y == 0 && value.z == 0) return;
    values.resize(i, Vec3d{0, 0, 0});
    values.push_back(value);
  };
  append(p.velocity, v);
  append(p.angularVelocity, w);
}

void Loader::parseParticles(const Fields& top) {
  const Entry* e = top.find("particles");
  if (!e || !isList(e->value, "particles", e->loc, "particle sets (each with 'list' or 'lattice')")) return;
  std::size_t s = 0;
  for (const YAML::Node& item : e->value) {
    const std::size_t setIndex = s++;
    const std::string path = at("particles", setIndex);
    const Loc itemLoc = locOf(item, e->loc);
    m_marks[path] = itemLoc;
    const auto f = mapping(item, path, e->loc, kParticleSetKeys);
    if (!f) continue;
    const int material = materialRef(*f, "material");
    const Entry* list = f->find("list");
    const Entry* lattice = f->find("lattice");
    if ((list != nullptr) == (lattice != nullptr)) {
      badValue(path, list ? "give either 'list' or 'lattice', not both (use two particle sets)" : "expected 'list' (explicit particles) or 'lattice' (a packed region)",
               itemLoc);
      continue;
    }
    ParticleSet set;
    set.first = m_config.particles.size();
    set.path = path;
    set.lattice = lattice != nullptr;
    if (list) {
      parseParticleList(list->value, f->child("list"), list->loc, material, set);
    } else {
      parseLattice(lattice->value, f->child("lattice"), lattice->loc, material, setIndex);
    }
    set.count = m_config.particles.size() - set.first;
    if (set.count > 0) m_sets.push_back(std::move(set));
  }
  compute::ParticleInit& p = m_config.particles;
  if (!p.velocity.empty()) p.velocity.resize(p.size(), Vec3d{0, 0, 0});
  if (!p.angularVelocity.empty()) p.angularVelocity.resize(p.size(), Vec3d{0, 0, 0});
}

void Loader::parseParticleList(const YAML::Node& list, const std::string& path, Loc loc, int material, ParticleSet& set) {
  if (!isList(list, path, loc, "particles ({position: [x, y, z], radius: r, ...})")) return;
  std::size_t j = 0;
  for (const YAML::Node& item : list) {
    const std::string ip = at(path, j++);
    const Loc itemLoc = locOf(item, loc);
    // Particles are pushed even when an entry is broken, so indices in validate()'s messages stay aligned; the
    // broken fields are in m_badPaths and validate()'s findings about them are dropped.
    Vec3d x{0, 0, 0}, v{0, 0, 0}, w{0, 0, 0};
    double r = 0;
    if (const auto f = mapping(item, ip, loc, kParticleKeys)) {
      get(*f, "position", x, true);
      get(*f, "radius", r, true);
      get(*f, "velocity", v);
      get(*f, "angular_velocity", w);
    }
    if (m_config.particles.size() >= kMaxParticles) {
      badValue(ip, "too many particles (the limit is " + std::to_string(kMaxParticles) + ")", itemLoc);
      return;
    }
    addParticle(x, r, v, w, material);
    set.entryLocs.push_back(itemLoc);
  }
}

void Loader::parseLattice(const YAML::Node& node, const std::string& path, Loc loc, int material, std::size_t setIndex) {
  const auto f = mapping(node, path, loc, kLatticeKeys);
  if (!f) return;
  Vec3d lo{0, 0, 0}, hi{0, 0, 0}, velocity{0, 0, 0};
  double radius = 0, spacing = 0, jitter = kDefaultJitter;
  int count = 0;
  const std::size_t before = m_errors.size();
  const bool haveBox = parseRegion(*f, "box", lo, hi, true);
  const bool haveRadius = get(*f, "radius", radius, true);
  const bool haveSpacing = get(*f, "spacing", spacing);
  get(*f, "jitter", jitter);
  get(*f, "velocity", velocity);
  const bool haveCount = get(*f, "count", count);
  if (m_errors.size() != before) return;  // a missing or mistyped key: nothing sensible to generate

  bool ok = true;
  auto bad = [&](std::string_view key, const std::string& message) {
    badValue(f->child(key), message, f->find(key) ? f->find(key)->loc : f->loc);
    ok = false;
  };
  if (!isFinite(lo) || !isFinite(hi) || !(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z)) {
    bad("box", "max " + vec(hi) + " must be > min " + vec(lo) + " on every axis");
  }
  if (!haveRadius || !std::isfinite(radius) || !(radius > 0)) bad("radius", num(radius) + " must be > 0");
  if (!haveSpacing) spacing = kDefaultSpacingFactor * radius;
  if (ok && (!std::isfinite(spacing) || !(spacing >= 2 * radius))) {
    bad("spacing", num(spacing) + " must be >= the diameter " + num(2 * radius) + " (centre-to-centre distance)");
  }
  if (!std::isfinite(jitter) || !(jitter >= 0)) {
    bad("jitter", num(jitter) + " must be >= 0");
  } else if (ok) {
    // Neighbours on the lattice stay apart when 2 * jitter * radius <= spacing - 2 * radius.
    const double maxJitter = (spacing - 2 * radius) / (2 * radius);
    if (jitter > maxJitter * (1 + 1e-12)) {
      bad("jitter", num(jitter) + " lets neighbouring particles overlap: with spacing " + num(spacing) + " and radius " + num(radius) +
                        " it must be <= " + num(maxJitter));
    }
  }
  if (haveCount && count < 1) bad("count", std::to_string(count) + " must be >= 1");
  if (!ok || !haveBox) return;

  const Vec3d size = hi - lo;
  const std::size_t nx = sitesAlong(size.x, radius, spacing), ny = sitesAlong(size.y, radius, spacing), nz = sitesAlong(size.z, radius, spacing);
  const double sites = static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz);
  if (sites == 0) {
    bad("box", "the box " + vec(lo) + " - " + vec(hi) + " is too small to hold one sphere of radius " + num(radius));
    return;
  }
  if (haveCount && static_cast<double>(count) > sites) {
    bad("count", std::to_string(count) + " is more than the " + num(sites) + " lattice sites that fit in the box (" + std::to_string(nx) + " x " +
                     std::to_string(ny) + " x " + std::to_string(nz) + ")");
    return;
  }
  const double wanted = haveCount ? static_cast<double>(count) : sites;
  if (wanted + static_cast<double>(m_config.particles.size()) > static_cast<double>(kMaxParticles)) {
    badValue(path, "would generate " + num(wanted) + " particles; the limit is " + std::to_string(kMaxParticles) + " in all (set 'count' or a larger spacing)",
             f->loc);
    return;
  }
  const auto target = static_cast<std::size_t>(wanted);
  m_config.particles.position.reserve(m_config.particles.size() + target);
  m_config.particles.radius.reserve(m_config.particles.size() + target);
  m_config.particles.material.reserve(m_config.particles.size() + target);

  std::mt19937_64 rng(splitMix64(m_config.sim.seed ^ splitMix64(static_cast<std::uint64_t>(setIndex))));
  const double amplitude = jitter * radius;
  const Vec3d cmin = lo + Vec3d{radius, radius, radius}, cmax = hi - Vec3d{radius, radius, radius};
  std::size_t made = 0;
  // x fastest, then y, then z: a count cap fills the lowest layers first.
  for (std::size_t iz = 0; iz < nz && made < target; ++iz) {
    for (std::size_t iy = 0; iy < ny && made < target; ++iy) {
      for (std::size_t ix = 0; ix < nx && made < target; ++ix, ++made) {
        const Vec3d site = cmin + Vec3d{static_cast<double>(ix) * spacing, static_cast<double>(iy) * spacing, static_cast<double>(iz) * spacing};
        Vec3d x{site.x + amplitude * symmetricUniform(rng), site.y + amplitude * symmetricUniform(rng), site.z + amplitude * symmetricUniform(rng)};
        // Clamping keeps every sphere inside the box; it only moves a centre back towards its site.
        x = {std::clamp(x.x, cmin.x, cmax.x), std::clamp(x.y, cmin.y, cmax.y), std::clamp(x.z, cmin.z, cmax.z)};
        addParticle(x, radius, velocity, Vec3d{0, 0, 0}, material);
      }
    }
  }
}

void Loader::parseMotion(const Fields& g, MeshMotion& motion) {
  const Entry* e = g.find("motion");
  if (!e) return;
  const auto f = mapping(e->value, g.child("motion"), e->loc, kMotionKeys);
  if (!f) return;
  get(*f, "velocity", motion.velocity);
  get(*f, "angular_velocity", motion.angularSpeed);
  get(*f, "axis_point", motion.axisPoint);
  get(*f, "start_time", motion.startTime);
  if (get(*f, "axis", motion.axis)) {
    const double len = norm(motion.axis);
    if (std::isfinite(len) && len > 0) motion.axis = (1.0 / len) * motion.axis;
  }
}

void Loader::parseGeometry(const Fields& top) {
  const Entry* e = top.find("geometry");
  if (!e || !isList(e->value, "geometry", e->loc, "walls (each with 'plane', 'box' or 'mesh')")) return;
  std::map<std::string, std::string> names;  // name -> geometry path
  std::size_t k = 0;
  for (const YAML::Node& item : e->value) {
    const std::size_t gi = k++;
    const std::string path = at("geometry", gi);
    const Loc itemLoc = locOf(item, e->loc);
    m_marks[path] = itemLoc;
    const auto f = mapping(item, path, e->loc, kGeometryKeys);
    if (!f) continue;
    const Entry* shapes[3] = {f->find("plane"), f->find("box"), f->find("mesh")};
    const int nShapes = (shapes[0] != nullptr) + (shapes[1] != nullptr) + (shapes[2] != nullptr);
    if (nShapes != 1) {
      badValue(path, nShapes == 0 ? "expected one of 'plane', 'box' or 'mesh'" : "give only one of 'plane', 'box' or 'mesh' per entry", itemLoc);
      continue;
    }
    const char* kind = shapes[0] ? "plane" : shapes[1] ? "box" : "mesh";
    std::string name = kind + std::to_string(gi);
    if (const Entry* n = f->find("name"); n && read(n->value, f->child("name"), n->loc, name)) {
      if (auto [it, inserted] = names.emplace(name, path); !inserted) {
        error(f->child("name"), "'" + name + "' is already the name of " + it->second, n->loc);
      }
    }
    const int material = materialRef(*f, "material");
    const std::size_t badBefore = m_badPaths.size();

    if (shapes[0]) {
      if (f->find("motion")) badValue(f->child("motion"), "planes cannot move; use a 'box' or 'mesh' for moving walls", f->find("motion")->loc);
      PlaneConfig plane;
      plane.name = name;
      plane.material = material;
      const std::string pp = f->child("plane");
      if (const auto pf = mapping(shapes[0]->value, pp, shapes[0]->loc, kPlaneKeys)) {
        get(*pf, "point", plane.point, true);
        if (get(*pf, "normal", plane.normal, true)) {
          const double len = norm(plane.normal);
          if (std::isfinite(len) && len > 0) plane.normal = (1.0 / len) * plane.normal;
        }
      }
      // A plane with an unusable point or normal is left out: validate() would only report particles against a placeholder.
      if (m_badPaths.size() != badBefore) continue;
      const std::string rc = at("planes", m_config.planes.size());
      m_pathMaps.push_back({rc + ".point", pp + ".point", true});
      m_pathMaps.push_back({rc + ".normal", pp + ".normal", true});
      m_pathMaps.push_back({rc + ".material", f->child("material"), true});
      m_pathMaps.push_back({rc, path, true});
      m_config.planes.push_back(std::move(plane));
      continue;
    }

    MeshConfig mesh;
    const std::string rc = at("meshes", m_config.meshes.size());
    if (shapes[1]) {
      const std::string bp = f->child("box");
      if (const auto bf = mapping(shapes[1]->value, bp, shapes[1]->loc, kBoxKeys)) {
        Vec3d lo{0, 0, 0}, hi{0, 0, 0};
        const bool haveLo = get(*bf, "min", lo, true);
        const bool haveHi = get(*bf, "max", hi, true);
        double resolution = 0;
        bool ok = haveLo && haveHi;
        if (ok && (!isFinite(lo) || !isFinite(hi) || !(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z))) {
          badValue(bp, "max " + vec(hi) + " must be > min " + vec(lo) + " on every axis", bf->loc);
          ok = false;
        }
        if (get(*bf, "resolution", resolution) && !(std::isfinite(resolution) && resolution > 0)) {
          badValue(bf->child("resolution"), num(resolution) + " must be > 0 (the longest triangle edge, m)", bf->find("resolution")->loc);
          ok = false;
        }
        std::array<bool, 6> open{};
        if (const Entry* o = bf->find("open")) {
          const std::string op = bf->child("open");
          if (o->value.IsSequence()) {
            for (std::size_t j = 0; j < o->value.size(); ++j) {
              const YAML::Node face = o->value[j];
              std::string faceName;
              if (!read(face, at(op, j), o->loc, faceName)) continue;
              const auto it = std::find(kBoxFaces.begin(), kBoxFaces.end(), faceName);
              if (it == kBoxFaces.end()) {
                badValue(at(op, j), unknownName("face", faceName, kBoxFaces, "Faces"), locOf(face, o->loc));
              } else {
                open[static_cast<std::size_t>(it - kBoxFaces.begin())] = true;
              }
            }
            if (std::all_of(open.begin(), open.end(), [](bool b) { return b; })) {
              badValue(op, "all six faces are open: the box would have no walls", o->loc);
              ok = false;
            }
          } else {
            badValue(op, "expected a list of face names (" + joinNames(kBoxFaces) + "), got " + describe(o->value), o->loc);
          }
        }
        if (ok && resolution > 0) {
          // Estimate before building: 2 triangles per cell, cells of side <= resolution / sqrt(2).
          const Vec3d d = hi - lo;
          const double c = std::sqrt(2.0) / resolution;
          const double cx = std::ceil(d.x * c), cy = std::ceil(d.y * c), cz = std::ceil(d.z * c);
          const double triangles = 2.0 * 2.0 * (cx * cy + cx * cz + cy * cz);
          if (triangles > static_cast<double>(kMaxBoxTriangles)) {
            badValue(bf->child("resolution"), num(resolution) + " would make about " + num(triangles) + " triangles; the limit is " +
                                                  std::to_string(kMaxBoxTriangles),
                     bf->find("resolution")->loc);
            ok = false;
          }
        }
        if (ok) mesh = makeBoxMesh(lo, hi, open, resolution);
      }
      // Generated vertices and triangles are the box's, not the user's: point at the box entry.
      m_pathMaps.push_back({rc + ".vertices", bp, false});
      m_pathMaps.push_back({rc + ".triangles", bp, false});
      m_pathMaps.push_back({rc + ".surfaces", bp, false});
    } else {
      const std::string mp = f->child("mesh");
      if (const auto mf = mapping(shapes[2]->value, mp, shapes[2]->loc, kMeshKeys)) {
        if (const Entry* v = mf->find("vertices")) {
          const std::string vp = mf->child("vertices");
          if (isList(v->value, vp, v->loc, "vertices [x, y, z]")) {
            for (std::size_t j = 0; j < v->value.size(); ++j) {
              const YAML::Node vn = v->value[j];
              Vec3d x{0, 0, 0};
              m_marks[at(vp, j)] = locOf(vn, v->loc);
              read(vn, at(vp, j), v->loc, x);
              mesh.vertices.push_back(x);
            }
          }
        } else {
          missing(*mf, "vertices", "a list of [x, y, z]");
        }
        if (const Entry* t = mf->find("triangles")) {
          const std::string tp = mf->child("triangles");
          if (isList(t->value, tp, t->loc, "triangles [i, j, k] (vertex indices)")) {
            for (std::size_t j = 0; j < t->value.size(); ++j) {
              const YAML::Node tn = t->value[j];
              const std::string ip = at(tp, j);
              const Loc tl = locOf(tn, t->loc);
              m_marks[ip] = tl;
              std::array<std::uint32_t, 3> tri{0, 0, 0};
              if (!tn.IsSequence() || tn.size() != 3) {
                badValue(ip, "expected a list of 3 vertex indices [i, j, k], got " + describe(tn), tl);
              } else {
                for (std::size_t c = 0; c < 3; ++c) {
                  const auto idx = parseInteger(tn[c]);
                  if (!idx || *idx < 0 || *idx > std::numeric_limits<std::uint32_t>::max()) {
                    badValue(ip, "corner " + std::to_string(c) + ": expected a vertex index >= 0, got " + describe(tn[c]), locOf(tn[c], tl));
                  } else {
                    tri[c] = static_cast<std::uint32_t>(*idx);
                  }
                }
              }
              mesh.triangles.push_back(tri);
            }
          }
        } else {
          missing(*mf, "triangles", "a list of [i, j, k] vertex indices");
        }
        if (const Entry* s = mf->find("surfaces")) {
          const std::string sp = mf->child("surfaces");
          if (isList(s->value, sp, s->loc, "surface numbers (one per triangle)")) {
            for (std::size_t j = 0; j < s->value.size(); ++j) {
              int surface = 0;
              read(s->value[j], at(sp, j), s->loc, surface);
              mesh.surface.push_back(surface);
            }
          }
        }
      }
      m_pathMaps.push_back({rc + ".vertices", mp + ".vertices", true});
      m_pathMaps.push_back({rc + ".triangles", mp + ".triangles", true});
      m_pathMaps.push_back({rc + ".surfaces", mp + ".surfaces", true});
    }
    mesh.name = name;
    mesh.material = material;
    parseMotion(*f, mesh.motion);
    m_pathMaps.push_back({rc + ".material", f->child("material"), true});
    m_pathMaps.push_back({rc + ".motion", f->child("motion"), true});
    m_pathMaps.push_back({rc, path, true});
    m_config.meshes.push_back(std::move(mesh));
  }
}

void Loader::parseOutput(const Fields& top) {
  const Entry* e = top.find("output");
  if (!e) return;
  if (const auto f = mapping(e->value, "output", e->loc, kOutputKeys)) get(*f, "file", m_outputFile);
}

// ---- validate() findings -> YAML paths and marks ------------------------------------------------------------------

// Strips the last `.name` or `[i]` component; false when nothing is left to strip.
bool parentPath(std::string& p) {
  if (p.empty()) return false;
  if (p.back() == ']') {
    const auto open = p.rfind('[');
    if (open == std::string::npos) return false;
    p.resize(open);
    return true;
  }
  const auto dot = p.rfind('.');
  if (dot == std::string::npos) {
    p.clear();
    return false;
  }
  p.resize(dot);
  return true;
}

Loc Loader::markFor(std::string yamlPath) const {
  do {
    if (const auto it = m_marks.find(yamlPath); it != m_marks.end()) return it->second;
  } while (parentPath(yamlPath));
  return {};
}

// True when `a` is `b`, or one lies under the other (`a.x`, `a[3]`).
bool related(const std::string& a, const std::string& b) {
  const std::string& shorter = a.size() <= b.size() ? a : b;
  const std::string& longer = a.size() <= b.size() ? b : a;
  if (longer.compare(0, shorter.size(), shorter) != 0) return false;
  return longer.size() == shorter.size() || longer[shorter.size()] == '.' || longer[shorter.size()] == '[';
}

bool Loader::isBad(const std::string& yamlPath) const {
  return std::any_of(m_badPaths.begin(), m_badPaths.end(), [&](const std::string& b) { return related(b, yamlPath); });
}

std::pair<std::string, Loc> Loader::locate(const std::string& rcPath, std::string& message) const {
  // particles.<field>[i]...: find the set particle i came from.
  static const std::string kParticles = "particles.";
  if (rcPath.compare(0, kParticles.size(), kParticles) == 0) {
    const auto open = rcPath.find('[');
    const auto close = rcPath.find(']');
    if (open == std::string::npos || close == std::string::npos || close < open) return {rcPath, {}};
    const std::string field = rcPath.substr(kParticles.size(), open - kParticles.size());
    const std::size_t i = std::stoull(rcPath.substr(open + 1, close - open - 1));
    const auto it = std::upper_bound(m_sets.begin(), m_sets.end(), i, [](std::size_t v, const ParticleSet& s) { return v < s.first; });
    if (it == m_sets.begin()) return {rcPath, {}};
    const ParticleSet& set = *(it - 1);
    if (i >= set.first + set.count) return {rcPath, {}};
    const std::size_t j = i - set.first;
    if (field == "material") return {set.path + ".material", markFor(set.path + ".material")};
    if (!set.lattice) {
      const std::string p = at(set.path + ".list", j) + "." + field;
      const auto mark = m_marks.find(p);
      return {p, mark != m_marks.end() ? mark->second : set.entryLocs[j]};
    }
    message = "particle " + std::to_string(j) + " of this lattice (" + rcPath + "): " + message;
    const std::string p = set.path + ".lattice" + (field == "radius" ? ".radius" : field == "velocity" ? ".velocity" : "");
    return {p, markFor(p)};
  }
  // planes[i] / meshes[i]: the longest mapped prefix.
  const PathMap* best = nullptr;
  for (const PathMap& m : m_pathMaps) {
    if (related(m.rcPrefix, rcPath) && m.rcPrefix.size() <= rcPath.size() && (!best || m.rcPrefix.size() > best->rcPrefix.size())) best = &m;
  }
  std::string yamlPath = rcPath;  // materials, pairs and simulation use the same names as the file
  if (best) {
    const std::string suffix = rcPath.substr(best->rcPrefix.size());
    if (best->keepSuffix) {
      yamlPath = best->yamlPath + suffix;
    } else {
      yamlPath = best->yamlPath;
      if (!suffix.empty()) message = "generated " + rcPath.substr(rcPath.find('.') + 1) + ": " + message;
    }
  }
  return {yamlPath, markFor(yamlPath)};
}

void Loader::appendValidation(const ErrorList& found) {
  for (const FieldError& fe : found.errors()) {
    std::string message = fe.message;
    auto [path, loc] = locate(fe.path, message);
    if (isBad(path)) continue;  // already reported as a parse error; validate() saw a placeholder
    error(path, message, loc);
  }
}

Result<LoadedScene> Loader::run(const std::string& yaml, const std::string& sourceName) {
  try {
    YAML::Node root;
    try {
      root = YAML::Load(yaml);
    } catch (const YAML::ParserException& ex) {
      error("", "YAML syntax error: " + ex.msg, locOf(ex.mark));
      return m_errors.toStatus(sourceName);
    }
    if (!root.IsDefined() || root.IsNull()) {
      error("", "the scene is empty; expected a mapping with keys " + joinNames(kTopKeys), {1, 1});
      return m_errors.toStatus(sourceName);
    }
    const auto top = mapping(root, "", {1, 1}, kTopKeys);
    if (!top) return m_errors.toStatus(sourceName);
    parseMaterials(*top);
    parseSimulation(*top);  // before particles: the lattice jitter uses simulation.seed
    parsePairs(*top);
    parseParticles(*top);
    parseGeometry(*top);
    parseOutput(*top);
    appendValidation(m_config.validate());
  } catch (const YAML::Exception& ex) {
    error("", "YAML error: " + ex.msg, locOf(ex.mark));
  } catch (const std::bad_alloc&) {
    error("", "out of memory while building the scene (too many particles or triangles?)", {});
  } catch (const std::exception& ex) {
    error("", std::string("internal error while loading the scene: ") + ex.what(), {});
  }
  if (!m_errors.empty()) return m_errors.toStatus(sourceName);
  return LoadedScene{std::move(m_config), sourceName, std::move(m_outputFile)};
}

}  // namespace

Result<LoadedScene> loadScene(const std::string& path) {
  std::string text;
  try {
    std::ifstream in(path, std::ios::binary);
    if (!in) return ioError("cannot open scene file '" + path + "': " + std::strerror(errno));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    if (in.bad()) return ioError("cannot read scene file '" + path + "'");
    text = std::move(buffer).str();
  } catch (const std::exception& ex) {
    return ioError("cannot read scene file '" + path + "': " + ex.what());
  }
  return loadSceneFromString(text, path);
}

Result<LoadedScene> loadSceneFromString(const std::string& yaml, const std::string& sourceName) {
  Loader loader;
  return loader.run(yaml, sourceName);
}

}  // namespace pflow::frontend
