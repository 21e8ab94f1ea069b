#include "frontend/scene/Loader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "compute/core/Format.h"

namespace pflow::frontend::detail {

using format::at;
using format::num;
using format::vec;

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
          if (triangles > static_cast<double>(m_options.maxTriangles)) {
            badValue(bf->child("resolution"), num(resolution) + " would make about " + num(triangles) + " triangles; the limit is " +
                                                  std::to_string(m_options.maxTriangles),
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

}  // namespace pflow::frontend::detail
