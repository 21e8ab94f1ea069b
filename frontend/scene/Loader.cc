#include "frontend/scene/Loader.h"

#include "compute/sph/SphFields.h"
#include <charconv>
#include <filesystem>

#include "compute/dem/ParticleFields.h"
#include <new>
#include <unordered_map>
#include <utility>
#include <vector>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "compute/core/Format.h"

namespace pflow::frontend::detail {

using format::at;
using format::num;
using format::vec;

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
    const YAML::Node keyNode = it->first;  // a copy: `it->` yields a temporary
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

bool Loader::read(const YAML::Node& n, const std::string& path, Loc loc, bool& out) {
  if (n.IsScalar() && !isQuoted(n)) {
    const std::string& s = n.Scalar();
    if (s == "true" || s == "True" || s == "TRUE") return out = true, true;
    if (s == "false" || s == "False" || s == "FALSE") return out = false, true;
  }
  badValue(path, "expected true or false, got " + describe(n), locOf(n, loc));
  return false;
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
      get(*f, "fixed", m.fixed);
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
      if (const Entry* c = f->find("cohesion")) {  // adhesion: {model: jkr | constant, work_of_adhesion: J/m^2}
        const std::string cp = f->child("cohesion");
        if (const auto cf = mapping(c->value, cp, c->loc, kCohesionKeys)) {
          std::string model;
          if (const Entry* me = cf->find("model")) {
            if (read(me->value, cf->child("model"), me->loc, model)) {
              if (model == "jkr") pair.cohesion = compute::CohesionModel::kJkr;
              else if (model == "constant") pair.cohesion = compute::CohesionModel::kConstant;
              else badValue(cf->child("model"), unknownName("model", model, kCohesionModels, "Choices"), me->loc);
            }
          } else {
            missing(*cf, "model", "jkr (Johnson-Kendall-Roberts) or constant (DMT's 2 pi dgamma R*)");
          }
          if (cf->find("work_of_adhesion")) get(*cf, "work_of_adhesion", pair.workOfAdhesion);
          else missing(*cf, "work_of_adhesion", "the work of adhesion dgamma (J/m^2)");
        }
      }
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
  const auto f = mapping(e->value, "simulation", e->loc, m_sph ? Keys(kSphSimulationKeys) : Keys(kSimulationKeys));
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
      s.precisionGiven = name == "double" || name == "float";
      if (name == "double") {
        s.precision = compute::Precision::kDouble;
      } else if (name == "float") {
        s.precision = compute::Precision::kFloat;
      } else {
        badValue("simulation.precision", unknownName("precision", name, kPrecisions, "Choices"), p->loc);
      }
    }
  }
  if (const Entry* d = f->find("decomposition")) {
    std::string name;
    if (read(d->value, "simulation.decomposition", d->loc, name)) {
      if (name == "sfc") {
        s.decomposition = compute::DecompositionKind::kSfc;
      } else if (name == "multisection") {
        s.decomposition = compute::DecompositionKind::kMultiSection;
      } else {
        badValue("simulation.decomposition", unknownName("decomposition", name, kDecompositions, "Choices"), d->loc);
      }
    }
  }
  if (const Entry* m = f->find("model")) {
    std::string name;
    if (read(m->value, "simulation.model", m->loc, name)) {
      if (name == "auto") s.model = compute::ModelMode::kAuto;
      else if (name == "full") s.model = compute::ModelMode::kFull;
      else badValue("simulation.model", unknownName("model", name, kModelModes, "Choices"), m->loc);
    }
  }
  // The error the scene tolerates on a quantity of the accuracy study; tolerance > 0 is checked by validate().
  if (const Entry* a = f->find("accuracy")) {
    if (const auto af = mapping(a->value, "simulation.accuracy", a->loc, kAccuracyKeys)) {
      compute::AccuracyTarget t;
      const bool haveQuantity = get(*af, "quantity", t.quantity, true);
      get(*af, "tolerance", t.tolerance, true);
      const compute::AccuracyTable& table =
          m_options.accuracyTable ? *m_options.accuracyTable : compute::AccuracyTable::builtIn();
      const std::vector<std::string> known = table.quantities();
      if (haveQuantity && !table.empty() && std::find(known.begin(), known.end(), t.quantity) == known.end()) {
        const Entry* q = af->find("quantity");
        badValue(af->child("quantity"), unknownName("quantity", t.quantity, known, "Quantities of the accuracy study"), q->loc);
      }
      s.accuracy = t;
    }
  }
  get(*f, "history_slots", s.historySlots);
  get(*f, "wall_history_slots", s.wallHistorySlots);
  get(*f, "threads", s.threads);
  get(*f, "seed", s.seed);
  get(*f, "max_overlap", s.maxOverlap);
  get(*f, "max_contacts", s.maxContacts);
  get(*f, "reproducible", s.reproducible);
  get(*f, "checkpoint_steps", s.checkpointSteps);
  if (const Entry* a = f->find("on_instability")) {
    std::string name;
    if (read(a->value, "simulation.on_instability", a->loc, name)) {
      if (name == "stop") {
        s.onInstability = compute::OnInstability::kStop;
      } else if (name == "reduce_dt") {
        s.onInstability = compute::OnInstability::kReduceDt;
      } else {
        badValue("simulation.on_instability", unknownName("on_instability", name, kInstabilityActions, "Choices"), a->loc);
      }
    }
  }
  // Physics switches: model no more than the scene needs. Off = the coefficient is zero for every material and
  // pair, so the least model (compute/dem/ModelChoice.h) leaves that part out.
  if (const Entry* p = f->find("physics")) {
    if (const auto pf = mapping(p->value, "simulation.physics", p->loc, kPhysicsKeys)) {
      if (const Entry* fr = pf->find("friction")) read(fr->value, pf->child("friction"), fr->loc, m_friction);
      if (const Entry* rr = pf->find("rolling_resistance")) read(rr->value, pf->child("rolling_resistance"), rr->loc, m_rollingResistance);
      if (const Entry* co = pf->find("cohesion")) read(co->value, pf->child("cohesion"), co->loc, m_cohesion);
    }
  }
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

void Loader::parseOutput(const Fields& top) {
  const Entry* e = top.find("output");
  if (!e) return;
  const auto f = mapping(e->value, "output", e->loc, m_sph ? Keys(kSphOutputKeys) : Keys(kOutputKeys));
  if (!f) return;
  get(*f, "file", m_outputFile);
  if (const Entry* c = f->find("checkpoint_interval")) {
    get(*f, "checkpoint_interval", m_checkpointInterval);
    if (!(m_checkpointInterval > 0) || !std::isfinite(m_checkpointInterval))
      badValue("output.checkpoint_interval", format::num(m_checkpointInterval) + " must be > 0 (simulated seconds between checkpoints)", c->loc);
  }
  if (m_sph) get(*f, "probe_interval", m_config.sph.probeInterval);
  if (const Entry* k = m_sph ? f->find("probe_sampling") : nullptr) {
    std::string name;
    if (read(k->value, "output.probe_sampling", k->loc, name)) {
      if (name == "instant" || name == "mean") m_config.sph.probeMean = name == "mean";
      else badValue("output.probe_sampling", unknownName("probe sampling", name, kProbeSamplings, "Choices"), k->loc);
    }
  }
  if (!m_sph) parseSeries(*f);
  const Entry* fields = f->find("fields");
  if (!fields || !isList(fields->value, "output.fields", fields->loc, "field names")) return;
  // The snapshot fields of the particle field table; id and position are always written (ParaView needs them).
  std::vector<std::string> known;
  if (m_sph) {
    for (const auto& info : compute::sph::kSphFieldTableOf<double>)
      if (info.flags & compute::kSnapshot) known.emplace_back(info.name);
  } else {
    for (const auto& info : compute::kFieldTable)
      if (info.flags & compute::kSnapshot) known.emplace_back(info.name);
  }
  for (std::size_t k = 0; k < fields->value.size(); ++k) {
    const std::string path = at("output.fields", k);
    std::string name;
    if (!read(fields->value[k], path, fields->loc, name)) continue;
    if (std::find(known.begin(), known.end(), name) == known.end()) {
      badValue(path, unknownName("field", name, known, "Snapshot fields"), locOf(fields->value[k], fields->loc));
    } else if (std::find(m_outputFields.begin(), m_outputFields.end(), name) == m_outputFields.end()) {
      m_outputFields.push_back(name);
    }
  }
  for (const char* always : {"id", "position"})
    if (std::find(m_outputFields.begin(), m_outputFields.end(), always) == m_outputFields.end()) m_outputFields.emplace_back(always);
}

// output.series_interval and output.flow_planes (DEM): what the run's time series samples, and how often.
void Loader::parseSeries(const Fields& f) {
  auto& series = m_config.series;
  if (const Entry* e = f.find("series_interval")) {
    get(f, "series_interval", series.interval);
    if (!(series.interval > 0) || !std::isfinite(series.interval))
      badValue("output.series_interval", format::num(series.interval) + " must be > 0 (simulated seconds between samples; leave it out "
                                         "to sample at every snapshot)", e->loc);
  }
  const Entry* e = f.find("flow_planes");
  if (!e || !isList(e->value, "output.flow_planes", e->loc, "flow planes")) return;
  for (std::size_t k = 0; k < e->value.size(); ++k) {
    const std::string path = at("output.flow_planes", k);
    const auto pf = mapping(e->value[k], path, e->loc, kFlowPlaneKeys);
    if (!pf) continue;
    compute::FlowPlane plane;
    const bool named = get(*pf, "name", plane.name, true);
    get(*pf, "point", plane.point, true);
    const bool normal = get(*pf, "normal", plane.normal, true);
    if (named && (plane.name.empty() || plane.name.size() > 64 ||
                  !std::all_of(plane.name.begin(), plane.name.end(), [](unsigned char c) { return std::isalnum(c) || c == '_' || c == '-' || c == '.'; })))
      badValue(path + ".name", "'" + plane.name + "': 1-64 of letters, digits, '_', '-', '.'", pf->loc);
    else if (named)
      for (const auto& other : series.flowPlanes)
        if (other.name == plane.name) badValue(path + ".name", "'" + plane.name + "' names another flow plane too", pf->loc);
    const double len = norm(plane.normal);
    if (normal && !(len > 0 && std::isfinite(len))) badValue(path + ".normal", "must be a non-zero vector", pf->loc);
    else if (normal) plane.normal = plane.normal * (1.0 / len);
    series.flowPlanes.push_back(plane);
  }
}

std::string Loader::resolvePath(const std::string& name) const {
  const std::filesystem::path p(name);
  if (p.is_absolute() || m_options.baseDir.empty()) return p.string();
  return (std::filesystem::path(m_options.baseDir) / p).string();
}

Result<std::string> Loader::resolveInput(const std::string& name) const {
  namespace fs = std::filesystem;
  if (name.empty()) return invalidArgument("the file name is empty");
  const fs::path p(name);
  if (m_options.confineFiles) {
    if (p.is_absolute())
      return invalidArgument("an absolute path is not allowed here: attach the file with the scene and name it relative to the scene");
    for (const fs::path& part : p)
      if (part == "..") return invalidArgument("'..' is not allowed here: name the file relative to the scene, inside its folder");
  }
  const std::string full = resolvePath(name);
  std::error_code ec;
  const fs::file_status st = fs::status(full, ec);
  if (ec || !fs::exists(st)) return ioError("cannot open '" + name + "': no such file");
  if (m_options.confineFiles) {
    const fs::path base = fs::canonical(m_options.baseDir.empty() ? fs::path(".") : fs::path(m_options.baseDir), ec);
    const fs::path real = fs::canonical(full, ec);
    const std::string b = base.string() + "/";
    if (ec || real.string().compare(0, b.size(), b) != 0)
      return invalidArgument("'" + name + "' is a link out of the scene's folder: attach the file itself");
  }
  if (!fs::is_regular_file(st)) return invalidArgument("'" + name + "' is not a regular file (a folder, FIFO, socket or device)");
  const std::uintmax_t bytes = fs::file_size(full, ec);
  if (ec) return ioError("cannot read the size of '" + name + "': " + ec.message());
  if (bytes > m_options.maxFileBytes)
    return invalidArgument("'" + name + "' is " + std::to_string(bytes) + " bytes; the limit is " + std::to_string(m_options.maxFileBytes));
  return full;
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
    if (set.inlineList) {
      const std::string p = at(set.path + ".list", j) + "." + field;
      const auto mark = m_marks.find(p);
      return {p, mark != m_marks.end() ? mark->second : set.entryLocs[j]};
    }
    // Generated or read from a file: name the particle within its set, point at the key that made it.
    message = "particle " + std::to_string(j) + " of this set (" + rcPath + "): " + message;
    const std::string key = set.method == "list" ? ".file"
                            : field == "radius" ? ".size"
                            : field == "velocity" ? ".velocity"
                            : field == "angular_velocity" ? ".angular_velocity"
                            : field == "position" ? ".region" : "";
    const std::string p = set.path + key;
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

namespace {

constexpr int kMaxNesting = 64;
// Nodes a scene may expand to, aliases followed: a few aliases of aliases ("billion laughs") would otherwise make
// every later walk over the document exponential. A scene with a million particles in a list is 1e6 + a few nodes.
constexpr std::size_t kMaxExpandedNodes = 20'000'000;

// Deepest nesting of flow collections ([..], {..}) and compact block sequences (`- - -`) in the text, so that
// pathological input is refused before the YAML parser recurses into it. Quotes and comments are skipped.
int textNesting(const std::string& text, int& line) {
  int depth = 0, deepest = 0, dashes = 0, currentLine = 1;
  char quote = 0;
  bool comment = false, lineStart = true;
  line = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++currentLine;
      comment = false;
      lineStart = true;
      dashes = 0;
      if (quote == '\'') quote = 0;  // unterminated single quote: let the parser report it
      continue;
    }
    if (comment) continue;
    if (quote) {
      if (c == quote) quote = 0;
      else if (quote == '"' && c == '\\') ++i;
      continue;
    }
    if (c == '#' && (i == 0 || text[i - 1] == ' ' || text[i - 1] == '\t' || text[i - 1] == '\n')) {
      comment = true;
      continue;
    }
    if (c == '"' || c == '\'') quote = c;
    if (c == '[' || c == '{') ++depth;
    if ((c == ']' || c == '}') && depth > 0) --depth;
    if (lineStart && c == '-' && (i + 1 == text.size() || text[i + 1] == ' ')) ++dashes;
    else if (c != ' ' && c != '\t') lineStart = false;
    if (depth + dashes > deepest) {
      deepest = depth + dashes;
      line = currentLine;
    }
  }
  return deepest;
}

// How many nodes a document expands to when its aliases are followed, counted in the time of its text: each
// collection's count is kept by its place in the text (an alias is the anchored node itself, at the anchor's place),
// so nine levels of ten aliases cost a hundred visits, not a billion. Saturates at kMaxExpandedNodes + 1. A cycle or
// nesting past kMaxNesting counts as one node here: checkStructure reports them.
class Expansion {
public:
  std::size_t count(const YAML::Node& node, int depth) {
    if (++m_visits > kMaxExpandedNodes) return kMaxExpandedNodes + 1;  // a memo defeated: still bounded
    if (!node.IsMap() && !node.IsSequence()) return 1;
    if (depth > kMaxNesting) return 1;
    for (const YAML::Node& a : m_open)
      if (a.is(node)) return 1;
    const long pos = node.Mark().pos;
    if (pos >= 0) {
      const auto it = m_memo.find(pos);
      if (it != m_memo.end() && it->second.first.is(node)) return it->second.second;
    }
    m_open.push_back(node);
    std::size_t total = 1;
    auto add = [&](const YAML::Node& child) { total = std::min(total + count(child, depth + 1), kMaxExpandedNodes + 1); };
    if (node.IsMap()) {
      for (auto it = node.begin(); it != node.end(); ++it) add(it->second);
    } else {
      for (std::size_t i = 0; i < node.size(); ++i) add(node[i]);
    }
    m_open.pop_back();
    if (pos >= 0) m_memo.insert_or_assign(pos, std::make_pair(node, total));
    return total;
  }

private:
  std::unordered_map<long, std::pair<YAML::Node, std::size_t>> m_memo;
  std::vector<YAML::Node> m_open;
  std::size_t m_visits = 0;
};

}  // namespace

// Refuses aliases that refer to a node containing them (a cycle) and nesting deeper than kMaxNesting. A document
// that expands past kMaxExpandedNodes was refused before (Expansion), so this walk is bounded.
void Loader::checkStructure(const YAML::Node& node, const std::string& path, std::vector<YAML::Node>& ancestors) {
  if (!node.IsMap() && !node.IsSequence()) return;
  for (const YAML::Node& a : ancestors) {
    if (a.is(node)) {
      badValue(path, "a cyclic alias: this node contains itself (an alias '*' refers to an anchor '&' around it)", locOf(node));
      return;
    }
  }
  if (ancestors.size() >= std::size_t(kMaxNesting)) {
    badValue(path, "nested deeper than " + std::to_string(kMaxNesting) + " levels", locOf(node));
    return;
  }
  ancestors.push_back(node);
  if (node.IsMap()) {
    for (auto it = node.begin(); it != node.end(); ++it) {
      const YAML::Node key = it->first;
      const std::string name = key.IsScalar() ? key.Scalar() : "?";
      checkStructure(it->second, path.empty() ? name : path + "." + name, ancestors);
    }
  } else {
    for (std::size_t i = 0; i < node.size(); ++i) checkStructure(node[i], at(path, i), ancestors);
  }
  ancestors.pop_back();
}

Result<LoadedScene> Loader::run(const std::string& yaml, const std::string& sourceName) {
  try {
    YAML::Node root;
    if (yaml.size() > m_options.maxSceneBytes) {
      error("", "the scene is " + std::to_string(yaml.size()) + " bytes; the limit is " + std::to_string(m_options.maxSceneBytes), {1, 1});
      return m_errors.toStatus(sourceName);
    }
    if (int line = 0; textNesting(yaml, line) > kMaxNesting) {
      error("", "the file is nested deeper than " + std::to_string(kMaxNesting) + " levels (brackets or '- ' items)", {line, 1});
      return m_errors.toStatus(sourceName);
    }
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
    if (Expansion().count(root, 0) > kMaxExpandedNodes) {
      error("", "the scene expands to more than " + std::to_string(kMaxExpandedNodes) +
                    " values when its aliases ('*name') are followed; repeat less, or give the values once",
            locOf(root));
      return m_errors.toStatus(sourceName);
    }
    std::vector<YAML::Node> ancestors;
    checkStructure(root, "", ancestors);
    if (!m_errors.empty()) return m_errors.toStatus(sourceName);
    // The solver decides which sections a scene has.
    if (root.IsMap() && root["solver"]) {
      const YAML::Node solver = root["solver"];
      const std::string name = solver.IsScalar() ? solver.Scalar() : std::string();
      if (name == "sph") m_sph = true;
      else if (name != "dem")
        badValue("solver", unknownName("solver", solver.IsScalar() ? name : describe(solver), kSolvers, "Choices"), locOf(solver, {1, 1}));
    }
    const auto top = mapping(root, "", {1, 1}, m_sph ? Keys(kSphTopKeys) : Keys(kTopKeys));
    if (!top) return m_errors.toStatus(sourceName);
    if (m_sph) {
      m_config.solver = compute::Solver::kSph;
      parseSimulation(*top);
      parseSphScene(*top);
      parseOutput(*top);
      parseSlurm(*top);
      appendValidation(m_config.validate());
      if (!m_errors.empty()) return m_errors.toStatus(sourceName);
      LoadedScene scene;
      scene.config = std::move(m_config);
      scene.sourcePath = sourceName;
      scene.outputFile = std::move(m_outputFile);
      scene.checkpointInterval = m_checkpointInterval;
      scene.outputFields = std::move(m_outputFields);
      scene.slurm = std::move(m_slurm);
      return scene;
    }
    parseMaterials(*top);
    parseSimulation(*top);  // before particles: generators use simulation.seed
    parsePairs(*top);
    parseGeometry(*top);    // before particles: they keep clear of walls and may fill a closed wall
    parseParticles(*top);
    parseOutput(*top);
    parseSlurm(*top);
    for (auto& m : m_config.materials) {
      if (!m_friction) m.friction = 0;
      if (!m_rollingResistance) m.rollingFriction = 0;
    }
    for (auto& pr : m_config.pairs) {
      if (!m_friction && pr.friction) pr.friction = 0.0;
      if (!m_rollingResistance && pr.rollingFriction) pr.rollingFriction = 0.0;
      if (!m_cohesion) pr.cohesion = compute::CohesionModel::kNone;
    }
    appendValidation(m_config.validate());
  } catch (const YAML::Exception& ex) {
    error("", "YAML error: " + ex.msg, locOf(ex.mark));
  } catch (const std::bad_alloc&) {
    error("", "out of memory while building the scene (too many particles or triangles?)", {});
  } catch (const std::exception& ex) {
    error("", std::string("internal error while loading the scene: ") + ex.what(), {});
  }
  if (!m_errors.empty()) return m_errors.toStatus(sourceName);
  m_config.surfaceNames.clear();
  for (const SurfaceInfo& s : m_surfaces) m_config.surfaceNames.push_back(s.name);
  LoadedScene scene;
  scene.config = std::move(m_config);
  scene.sourcePath = sourceName;
  scene.outputFile = std::move(m_outputFile);
  scene.checkpointInterval = m_checkpointInterval;
  scene.outputFields = std::move(m_outputFields);
  scene.surfaces = std::move(m_surfaces);
  scene.sets = std::move(m_setInfo);
  scene.files = std::move(m_files);
  scene.slurm = std::move(m_slurm);
  return scene;
}

}  // namespace pflow::frontend::detail
