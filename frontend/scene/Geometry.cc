#include "frontend/scene/Loader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "compute/core/Format.h"
#include "frontend/geometry/MeshIO.h"
#include "frontend/geometry/MeshOps.h"

namespace pflow::frontend::detail {

using format::at;
using format::num;
using format::vec;

void Loader::parseMotion(const Fields& g, MeshMotion& motion) {
  const Entry* e = g.find("motion");
  if (!e) return;
  const auto f = mapping(e->value, g.child("motion"), e->loc, kMotionKeys);
  if (!f) return;
  get(*f, "velocity", motion.velocity);
  get(*f, "angular_velocity", motion.angularSpeed);
  get(*f, "axis_point", motion.axisPoint);
  get(*f, "start_time", motion.startTime);
  if (const Entry* p = f->find("velocity_profile"); p && isList(p->value, f->child("velocity_profile"), p->loc, "[time, vx, vy, vz] points")) {
    for (std::size_t k = 0; k < p->value.size(); ++k) {  // [tau, vx, vy, vz]: s after start_time, m/s
      const std::string path = at(f->child("velocity_profile"), k);
      const YAML::Node& node = p->value[k];
      if (!node.IsSequence() || node.size() != 4) {
        badValue(path, "a point is [time, vx, vy, vz] (s after start_time, m/s)", p->loc);
        continue;
      }
      double row[4];
      bool ok = true;
      for (std::size_t c = 0; c < 4; ++c) ok = read(node[c], at(path, c), p->loc, row[c]) && ok;
      if (ok) motion.profile.push_back({row[0], {row[1], row[2], row[3]}});
    }
  }
  if (const Entry* v = f->find("vibration")) {  // a shaker: amplitude [m] and frequency [Hz], phase [rad]
    if (const auto vf = mapping(v->value, f->child("vibration"), v->loc, kVibrationKeys)) {
      get(*vf, "amplitude", motion.vibration, true);
      get(*vf, "frequency", motion.frequency, true);
      get(*vf, "phase", motion.phase);
    }
  }
  if (const Entry* d = f->find("drive")) {  // a wall moved by a force or torque (compute/dem/WallDrive.h)
    if (const auto df = mapping(d->value, f->child("drive"), d->loc, kDriveKeys)) {
      compute::MeshMotion::Drive drive;
      get(*df, "mass", drive.mass);
      get(*df, "force", drive.force);
      get(*df, "force_limit", drive.forceLimit);
      get(*df, "moment_of_inertia", drive.inertia);
      get(*df, "torque", drive.torque);
      get(*df, "torque_limit", drive.torqueLimit);
      motion.drive = drive;
    }
  }
  if (get(*f, "axis", motion.axis)) {
    const double len = norm(motion.axis);
    if (std::isfinite(len) && len > 0) motion.axis = (1.0 / len) * motion.axis;
  }
}

// ---- shape parameters -------------------------------------------------------------------------------------------

bool Loader::positive(const Fields& f, std::string_view key, double& out, bool required, bool allowZero) {
  const Entry* e = f.find(key);
  if (!e) {
    if (required) missing(f, key);
    return false;
  }
  if (!read(e->value, f.child(key), e->loc, out)) return false;
  if (std::isfinite(out) && (allowZero ? out >= 0 : out > 0)) return true;
  badValue(f.child(key), num(out) + (allowZero ? " must be >= 0" : " must be > 0"), e->loc);
  return false;
}

bool Loader::unitAxis(const Fields& f, std::string_view key, Vec3d& axis) {
  const Entry* e = f.find(key);
  if (!e) return true;  // the default axis
  if (!read(e->value, f.child(key), e->loc, axis)) return false;
  const double len = norm(axis);
  if (!std::isfinite(len) || !(len > 0)) {
    badValue(f.child(key), vec(axis) + " must be a finite, nonzero direction", e->loc);
    return false;
  }
  axis = (1.0 / len) * axis;
  return true;
}

bool Loader::parseTessellation(const Fields& f, Tessellation& t) {
  bool ok = true;
  if (f.find("resolution")) ok &= positive(f, "resolution", t.maxEdge, false);
  if (const Entry* e = f.find("segments")) {
    int segments = 0;
    if (!read(e->value, f.child("segments"), e->loc, segments)) return false;
    if (segments < 3 || segments > 100000) {
      badValue(f.child("segments"), std::to_string(segments) + " is outside [3, 100000] (segments around a full circle)", e->loc);
      return false;
    }
    t.maxAngle = 2 * std::numbers::pi / segments * (1 + 1e-12);  // exactly `segments` when the radius decides nothing else
  }
  return ok;
}

bool Loader::parseSide(const Fields& f, bool& inside) {
  const Entry* e = f.find("side");
  if (!e) return true;
  std::string side;
  if (!read(e->value, f.child("side"), e->loc, side)) return false;
  if (side != "inside" && side != "outside") {
    badValue(f.child("side"), unknownName("side", side, kSides, "Choices") + " (where the particles are)", e->loc);
    return false;
  }
  inside = side == "inside";
  return true;
}

bool Loader::parseOpenings(const Fields& f, Keys names, std::string_view what, std::vector<bool>& open) {
  const Entry* e = f.find("open");
  if (!e) return true;
  const std::string path = f.child("open");
  if (!e->value.IsSequence()) {
    badValue(path, "expected a list of names (" + joinNames(names) + "), got " + describe(e->value), e->loc);
    return false;
  }
  std::fill(open.begin(), open.end(), false);
  bool ok = true;
  for (std::size_t j = 0; j < e->value.size(); ++j) {
    const YAML::Node item = e->value[j];
    std::string name;
    if (!read(item, at(path, j), e->loc, name)) {
      ok = false;
      continue;
    }
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      badValue(at(path, j), unknownName(what, name, names, "Choices"), locOf(item, e->loc));
      ok = false;
    } else {
      open[static_cast<std::size_t>(it - names.begin())] = true;
    }
  }
  return ok;
}

void Loader::shapeError(const Fields& f, const Status& s) { badValue(f.path, s.message(), f.loc); }

// ---- shapes -------------------------------------------------------------------------------------------------------

std::optional<TriMesh> Loader::parseBox(const Fields& f) {
  BoxSpec spec;
  Tessellation tess;
  bool inside = true;
  const bool haveLo = get(f, "min", spec.min, true);
  const bool haveHi = get(f, "max", spec.max, true);
  bool ok = haveLo && haveHi;
  if (ok && (!isFinite(spec.min) || !isFinite(spec.max) || !(spec.max.x > spec.min.x && spec.max.y > spec.min.y && spec.max.z > spec.min.z))) {
    badValue(f.path, "max " + vec(spec.max) + " must be > min " + vec(spec.min) + " on every axis", f.loc);
    ok = false;
  }
  ok &= parseTessellation(f, tess) && parseSide(f, inside);
  std::vector<bool> open(kBoxFaces.size(), false);
  if (!parseOpenings(f, kBoxFaces, "face", open)) ok = false;
  if (std::all_of(open.begin(), open.end(), [](bool b) { return b; })) {
    badValue(f.child("open"), "all six faces are open: the box would have no walls", f.find("open")->loc);
    ok = false;
  }
  if (!ok) return std::nullopt;
  for (std::size_t k = 0; k < open.size(); ++k) spec.open[k] = open[k];
  auto mesh = tessellate(spec, tess);
  if (!mesh) return shapeError(f, mesh.status()), std::nullopt;
  return inside ? asContainer(std::move(mesh).value()) : std::move(mesh).value();
}

std::optional<TriMesh> Loader::parseCylinder(const Fields& f) {
  CylinderSpec spec;
  Tessellation tess;
  bool inside = true;
  bool ok = get(f, "base", spec.base, true);
  ok &= unitAxis(f, "axis", spec.axis);
  ok &= positive(f, "radius", spec.radius, true);
  ok &= positive(f, "height", spec.height, true);
  ok &= parseTessellation(f, tess) && parseSide(f, inside);
  std::vector<bool> open(2, false);
  ok &= parseOpenings(f, kCapNames, "cap", open);
  if (!ok) return std::nullopt;
  spec.openBottom = open[0];
  spec.openTop = open[1];
  auto mesh = tessellate(spec, tess);
  if (!mesh) return shapeError(f, mesh.status()), std::nullopt;
  return inside ? asContainer(std::move(mesh).value()) : std::move(mesh).value();
}

std::optional<TriMesh> Loader::parseCone(const Fields& f) {
  FrustumSpec spec;
  Tessellation tess;
  bool inside = true;
  bool ok = get(f, "base", spec.base, true);
  ok &= unitAxis(f, "axis", spec.axis);
  ok &= positive(f, "bottom_radius", spec.bottomRadius, true, true);
  ok &= positive(f, "top_radius", spec.topRadius, true, true);
  ok &= positive(f, "height", spec.height, true);
  ok &= parseTessellation(f, tess) && parseSide(f, inside);
  std::vector<bool> open(2, false);
  ok &= parseOpenings(f, kCapNames, "cap", open);
  if (ok && spec.bottomRadius == 0 && spec.topRadius == 0) {
    badValue(f.path, "bottom_radius and top_radius are both 0: at least one must be > 0", f.loc);
    ok = false;
  }
  if (!ok) return std::nullopt;
  spec.openBottom = open[0];
  spec.openTop = open[1];
  auto mesh = tessellate(spec, tess);
  if (!mesh) return shapeError(f, mesh.status()), std::nullopt;
  return inside ? asContainer(std::move(mesh).value()) : std::move(mesh).value();
}

std::optional<TriMesh> Loader::parseHopper(const Fields& f) {
  HopperSpec spec;
  Tessellation tess;
  bool ok = get(f, "orifice", spec.orifice, true);
  ok &= unitAxis(f, "axis", spec.axis);
  ok &= positive(f, "orifice_radius", spec.orificeRadius, true);
  ok &= positive(f, "top_radius", spec.topRadius, true);
  ok &= positive(f, "cone_height", spec.coneHeight, true);
  if (f.find("cylinder_height")) ok &= positive(f, "cylinder_height", spec.cylinderHeight, false, true);
  ok &= parseTessellation(f, tess);
  std::vector<bool> open = {true, true};  // a hopper is open at the orifice and the top unless told otherwise
  ok &= parseOpenings(f, kHopperOpenings, "opening", open);
  if (ok && !(spec.orificeRadius < spec.topRadius)) {
    badValue(f.child("orifice_radius"), num(spec.orificeRadius) + " must be < top_radius " + num(spec.topRadius) +
                                            " (the cone narrows down to the orifice)",
             f.find("orifice_radius")->loc);
    ok = false;
  }
  if (!ok) return std::nullopt;
  spec.openOrifice = open[0];
  spec.openTop = open[1];
  auto mesh = tessellate(spec, tess);
  if (!mesh) return shapeError(f, mesh.status()), std::nullopt;
  return asContainer(std::move(mesh).value());
}

std::optional<TriMesh> Loader::parseDrum(const Fields& f, MeshMotion& motion) {
  DrumSpec spec;
  Tessellation tess;
  bool ok = get(f, "center", spec.centre, true);
  ok &= unitAxis(f, "axis", spec.axis);
  ok &= positive(f, "radius", spec.radius, true);
  ok &= positive(f, "length", spec.length, true);
  ok &= parseTessellation(f, tess);
  double speed = 0, start = 0;
  if (get(f, "angular_velocity", speed) && !std::isfinite(speed)) {
    badValue(f.child("angular_velocity"), num(speed) + " must be finite (rad/s)", f.find("angular_velocity")->loc);
    ok = false;
  }
  if (f.find("start_time")) ok &= positive(f, "start_time", start, false, true);
  if (!ok) return std::nullopt;
  // The drum turns about its own axis, through its centre.
  motion.axis = spec.axis;
  motion.axisPoint = spec.centre;
  motion.angularSpeed = speed;
  motion.startTime = start;
  auto mesh = tessellate(spec, tess);
  if (!mesh) return shapeError(f, mesh.status()), std::nullopt;
  return asContainer(std::move(mesh).value());
}

std::optional<TriMesh> Loader::parseMesh(const Fields& f) {
  const Entry* file = f.find("file");
  const bool inlineGiven = f.find("vertices") || f.find("triangles") || f.find("surfaces");
  if (file && inlineGiven) {
    badValue(f.path, "give either 'file' or inline 'vertices' and 'triangles', not both", f.loc);
    return std::nullopt;
  }
  std::optional<TriMesh> mesh;
  if (file) {
    std::string name;
    if (!read(file->value, f.child("file"), file->loc, name)) return std::nullopt;
    m_files.push_back(name);
    auto input = resolveInput(name);
    if (!input) {
      badValue(f.child("file"), input.status().message(), file->loc);
      return std::nullopt;
    }
    auto loaded = readMeshFile(input.value());
    if (!loaded) {
      badValue(f.child("file"), loaded.status().message(), file->loc);
      return std::nullopt;
    }
    mesh = std::move(loaded).value();
  } else {
    mesh = parseInlineMesh(f);
    if (!mesh) return std::nullopt;
  }
  // Placement: scale, then rotate about the origin, then translate.
  double scale = 1, angle = 0;
  Vec3d translate{0, 0, 0}, axis{0, 0, 1};
  bool ok = true;
  if (f.find("scale")) ok &= positive(f, "scale", scale, false);
  if (f.find("translate")) ok &= get(f, "translate", translate) && isFinite(translate);
  if (const Entry* r = f.find("rotate")) {
    if (const auto rf = mapping(r->value, f.child("rotate"), r->loc, kRotateKeys)) {
      ok &= unitAxis(*rf, "axis", axis);
      ok &= get(*rf, "angle", angle, true) && std::isfinite(angle);
    } else {
      ok = false;
    }
  }
  bool flipIt = false;
  if (const Entry* fl = f.find("flip")) ok &= read(fl->value, f.child("flip"), fl->loc, flipIt);
  if (!ok) return std::nullopt;
  if (scale != 1 || angle != 0 || translate.x != 0 || translate.y != 0 || translate.z != 0) {
    auto placed = transform(std::move(*mesh), scale, axis, angle, translate);
    if (!placed) return shapeError(f, placed.status()), std::nullopt;
    mesh = std::move(placed).value();
  }
  if (flipIt) mesh = flip(std::move(*mesh));
  return mesh;
}

// Inline `vertices`, `triangles` and `surfaces`. Index and degeneracy problems are left to RunConfig::validate(),
// which names the triangle; the mesh keeps one entry per YAML item so those names line up.
std::optional<TriMesh> Loader::parseInlineMesh(const Fields& mf) {
  TriMesh mesh;
  if (const Entry* v = mf.find("vertices")) {
    const std::string vp = mf.child("vertices");
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
    missing(mf, "vertices", "a list of [x, y, z]");
  }
  if (const Entry* t = mf.find("triangles")) {
    const std::string tp = mf.child("triangles");
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
    missing(mf, "triangles", "a list of [i, j, k] vertex indices");
  }
  if (const Entry* s = mf.find("surfaces")) {
    const std::string sp = mf.child("surfaces");
    if (isList(s->value, sp, s->loc, "surface numbers (one per triangle)")) {
      for (std::size_t j = 0; j < s->value.size(); ++j) {
        int surface = 0;
        read(s->value[j], at(sp, j), s->loc, surface);
        mesh.surface.push_back(surface);
      }
    }
  }
  return mesh;
}

std::optional<TriMesh> Loader::parseShape(std::string_view kind, const Entry& shape, const std::string& path, MeshMotion& motion,
                                          bool& motionGiven) {
  const Keys keys = kind == "box" ? Keys(kBoxKeys)
                    : kind == "cylinder" ? Keys(kCylinderKeys)
                    : kind == "cone" ? Keys(kConeKeys)
                    : kind == "hopper" ? Keys(kHopperKeys)
                    : kind == "drum" ? Keys(kDrumKeys)
                                     : Keys(kMeshKeys);
  const auto f = mapping(shape.value, path, shape.loc, keys);
  if (!f) return std::nullopt;
  if (kind == "box") return parseBox(*f);
  if (kind == "cylinder") return parseCylinder(*f);
  if (kind == "cone") return parseCone(*f);
  if (kind == "hopper") return parseHopper(*f);
  if (kind == "drum") {
    motionGiven = true;
    return parseDrum(*f, motion);
  }
  return parseMesh(*f);
}

// ---- the geometry section -----------------------------------------------------------------------------------------

void Loader::parseGeometry(const Fields& top) {
  const Entry* e = top.find("geometry");
  if (!e || !isList(e->value, "geometry", e->loc, "walls (each with one of " + joinNames(kShapeKinds) + ")")) return;
  std::map<std::string, std::string> names;  // name -> geometry path
  std::size_t triangles = 0;
  for (std::size_t gi = 0; gi < e->value.size(); ++gi) {
    const YAML::Node item = e->value[gi];
    const std::string path = at("geometry", gi);
    const Loc itemLoc = locOf(item, e->loc);
    m_marks[path] = itemLoc;
    const auto f = mapping(item, path, e->loc, kGeometryKeys);
    if (!f) continue;
    const Entry* shape = nullptr;
    std::string_view kind;
    int nShapes = 0;
    for (std::string_view k : kShapeKinds) {
      if (const Entry* s = f->find(k)) {
        ++nShapes;
        if (!shape) { shape = s; kind = k; }
      }
    }
    if (nShapes != 1) {
      badValue(path, nShapes == 0 ? "expected one shape key: " + joinNames(kShapeKinds) : "give only one shape per entry (use two entries)", itemLoc);
      continue;
    }
    std::string name = std::string(kind) + std::to_string(gi);
    if (const Entry* n = f->find("name"); n && read(n->value, f->child("name"), n->loc, name)) {
      if (name.find('/') != std::string::npos) {
        error(f->child("name"), "'" + name + "' may not contain '/' (it separates wall and surface in surface names)", n->loc);
      } else if (auto [it, inserted] = names.emplace(name, path); !inserted) {
        error(f->child("name"), "'" + name + "' is already the name of " + it->second, n->loc);
      }
    }
    const int material = materialRef(*f, "material");
    const std::size_t badBefore = m_badPaths.size();
    const std::string shapePath = f->child(kind);

    if (kind == "plane") {
      if (f->find("motion")) badValue(f->child("motion"), "planes cannot move; use a box or mesh for moving walls", f->find("motion")->loc);
      PlaneConfig plane;
      plane.name = name;
      plane.material = material;
      if (const auto pf = mapping(shape->value, shapePath, shape->loc, kPlaneKeys)) {
        get(*pf, "point", plane.point, true);
        if (get(*pf, "normal", plane.normal, true)) {
          const double len = norm(plane.normal);
          if (std::isfinite(len) && len > 0) plane.normal = (1.0 / len) * plane.normal;
        }
      }
      // A plane with an unusable point or normal is left out: validate() would only report particles against a placeholder.
      if (m_badPaths.size() != badBefore) continue;
      plane.surface = static_cast<std::int32_t>(m_surfaces.size());
      m_surfaces.push_back({plane.surface, name, name, 0, 0.0});
      const std::string rc = at("planes", m_config.planes.size());
      m_pathMaps.push_back({rc + ".point", shapePath + ".point", true});
      m_pathMaps.push_back({rc + ".normal", shapePath + ".normal", true});
      m_pathMaps.push_back({rc + ".material", f->child("material"), true});
      m_pathMaps.push_back({rc, path, true});
      m_config.planes.push_back(std::move(plane));
      continue;
    }

    MeshMotion motion;
    bool motionFromShape = false;
    auto mesh = parseShape(kind, *shape, shapePath, motion, motionFromShape);
    if (const Entry* m = f->find("motion")) {
      if (motionFromShape) {
        badValue(f->child("motion"), "a drum turns by its own 'angular_velocity' (and 'start_time'); 'motion' is not allowed here", m->loc);
      } else {
        parseMotion(*f, motion);
      }
    }
    if (!mesh) continue;
    triangles += mesh->triangles.size();
    if (triangles > m_options.maxTriangles) {
      badValue(shapePath, "the walls so far have " + std::to_string(triangles) + " triangles; the limit is " +
                              std::to_string(m_options.maxTriangles) + " (use a coarser 'resolution' or fewer 'segments')",
               shape->loc);
      return;
    }

    // Scene-wide surface numbers: this wall's local surfaces 0..k-1 become base..base+k-1, kept even when a
    // face is open (no triangles), so a number never changes with the options.
    const auto base = static_cast<std::int32_t>(m_surfaces.size());
    std::int32_t local = static_cast<std::int32_t>(mesh->surfaceNames.size());
    for (std::int32_t s : mesh->surface) local = std::max(local, s + 1);
    local = std::max<std::int32_t>(local, 1);
    std::vector<std::size_t> count(static_cast<std::size_t>(local), 0);
    std::vector<double> surfaceArea(static_cast<std::size_t>(local), 0.0);
    const bool numbered = mesh->surface.size() == mesh->triangles.size();
    // The corners index real vertices (checkIndices would also ask for one surface number a triangle, which an inline
    // mesh without `surfaces` does not give: its area came out 0).
    const bool indicesOk = std::all_of(mesh->triangles.begin(), mesh->triangles.end(), [&](const auto& tri) {
      return tri[0] < mesh->vertices.size() && tri[1] < mesh->vertices.size() && tri[2] < mesh->vertices.size();
    });
    for (std::size_t t = 0; t < mesh->triangles.size(); ++t) {
      const std::int32_t s = numbered ? mesh->surface[t] : 0;
      if (s < 0) continue;  // reported by validate()
      ++count[static_cast<std::size_t>(s)];
      if (indicesOk) surfaceArea[static_cast<std::size_t>(s)] += 0.5 * norm(areaNormal(*mesh, t));
    }
    for (std::int32_t s = 0; s < local; ++s) {
      const auto us = static_cast<std::size_t>(s);
      std::string part = us < mesh->surfaceNames.size() && !mesh->surfaceNames[us].empty() ? mesh->surfaceNames[us] : "";
      const std::string surfaceName = local == 1 && part.empty() ? name : name + "/" + (part.empty() ? "surface" + std::to_string(s) : part);
      m_surfaces.push_back({base + s, surfaceName, name, count[us], surfaceArea[us]});
    }

    MeshConfig mc;
    mc.name = name;
    mc.material = material;
    mc.motion = motion;
    mc.vertices = std::move(mesh->vertices);
    mc.triangles = std::move(mesh->triangles);
    mc.surface.resize(mc.triangles.size(), base);
    if (numbered)
      for (std::size_t t = 0; t < mc.triangles.size(); ++t) mc.surface[t] = mesh->surface[t] < 0 ? mesh->surface[t] : base + mesh->surface[t];
    const std::string rc = at("meshes", m_config.meshes.size());
    const bool inlineMesh = kind == "mesh" && !f->find("mesh")->value["file"];
    if (inlineMesh) {
      m_pathMaps.push_back({rc + ".vertices", shapePath + ".vertices", true});
      m_pathMaps.push_back({rc + ".triangles", shapePath + ".triangles", true});
      m_pathMaps.push_back({rc + ".surfaces", shapePath + ".surfaces", true});
    } else {  // generated or read from a file: point at the shape entry
      m_pathMaps.push_back({rc + ".vertices", shapePath, false});
      m_pathMaps.push_back({rc + ".triangles", shapePath, false});
      m_pathMaps.push_back({rc + ".surfaces", shapePath, false});
    }
    m_pathMaps.push_back({rc + ".material", f->child("material"), true});
    m_pathMaps.push_back({rc + ".motion", f->child(motionFromShape ? kind : "motion"), true});
    m_pathMaps.push_back({rc, path, true});
    m_config.meshes.push_back(std::move(mc));
  }
}

}  // namespace pflow::frontend::detail
