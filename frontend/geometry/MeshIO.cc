#include "frontend/geometry/MeshIO.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <vector>

#include "frontend/geometry/MeshOps.h"

namespace pflow::frontend {
namespace {

static_assert(std::endian::native == std::endian::little, "binary STL is little-endian; add byte swapping for this host");

constexpr std::size_t kStlHeader = 84;  // 80-byte header + uint32 triangle count
constexpr std::size_t kStlRecord = 50;  // normal, 3 vertices (12 float32) + uint16 attribute

Status fileError(const std::string& path, const std::string& what) { return ioError("'" + path + "': " + what); }
Status formatError(const std::string& path, const std::string& what) { return invalidArgument("'" + path + "': " + what); }
Status lineError(const std::string& path, std::size_t line, const std::string& what) {
  return invalidArgument("'" + path + "' line " + std::to_string(line) + ": " + what);
}

Result<std::string> readWholeFile(const std::string& path) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st)) return fileError(path, "cannot open: no such file");
  if (std::filesystem::is_directory(st)) return fileError(path, "cannot read: is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) return fileError(path, std::string("cannot open: ") + std::strerror(errno));
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return fileError(path, "cannot determine the file size");
  in.seekg(0, std::ios::beg);
  std::string data(static_cast<std::size_t>(size), '\0');
  if (size > 0 && !in.read(data.data(), size)) return fileError(path, "read failed");
  if (data.empty()) return formatError(path, "the file is empty");
  return data;
}

// --- shared final checks ----------------------------------------------------------------------------------------------

// Zero triangles or degenerate ones are errors (or dropped, by option); `where` names triangle t
// for the message (file order).
template <class Where>
Status finishMesh(TriMesh& mesh, const std::string& path, const MeshReadOptions& options, Where where) {
  if (mesh.triangles.empty()) return formatError(path, "the file has no triangles");
  const std::vector<std::size_t> bad = degenerateTriangles(mesh);
  if (bad.empty()) return Status::ok();
  if (!options.dropDegenerate) {
    return formatError(path, std::to_string(bad.size()) + " degenerate (zero-area) triangle" + (bad.size() == 1 ? "" : "s") +
                                 "; first: " + where(bad.front()));
  }
  std::vector<bool> drop(mesh.triangles.size(), false);
  for (std::size_t t : bad) drop[t] = true;
  std::size_t k = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (drop[t]) continue;
    mesh.triangles[k] = mesh.triangles[t];
    mesh.surface[k++] = mesh.surface[t];
  }
  mesh.triangles.resize(k);
  mesh.surface.resize(k);
  if (mesh.triangles.empty()) return formatError(path, "every triangle is degenerate (zero area)");
  return Status::ok();
}

// --- STL --------------------------------------------------------------------------------------------------------------

// Triangle soup -> shared vertices: bit-identical coordinates weld (the STL way of saying "same vertex").
Result<TriMesh> finishStl(TriMesh soup, const std::string& path, const MeshReadOptions& options, std::vector<std::size_t> lineOf) {
  auto where = [&](std::size_t t) {
    return lineOf.empty() ? "triangle " + std::to_string(t) : "facet at line " + std::to_string(lineOf[t]);
  };
  if (Status s = finishMesh(soup, path, options, where); !s) return s;
  return weldVertices(soup, 0);
}

void pushSoupTriangle(TriMesh& soup, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const auto base = static_cast<std::uint32_t>(soup.vertices.size());
  soup.vertices.push_back(a);
  soup.vertices.push_back(b);
  soup.vertices.push_back(c);
  soup.triangles.push_back({base, base + 1, base + 2});
  soup.surface.push_back(0);
}

std::uint32_t stlDeclaredCount(std::string_view data) {
  std::uint32_t n;
  std::memcpy(&n, data.data() + 80, sizeof n);
  return n;
}

Result<TriMesh> parseBinaryStl(std::string_view data, const std::string& path, const MeshReadOptions& options) {
  const std::uint32_t n = stlDeclaredCount(data);
  TriMesh soup;
  soup.surfaceNames = {"stl"};
  soup.vertices.reserve(3 * static_cast<std::size_t>(n));
  soup.triangles.reserve(n);
  soup.surface.reserve(n);
  for (std::size_t t = 0; t < n; ++t) {
    float f[9];
    std::memcpy(f, data.data() + kStlHeader + kStlRecord * t + 12, sizeof f);  // skip the stored normal
    for (int k = 0; k < 9; ++k) {
      if (!std::isfinite(f[k])) {
        return formatError(path, "triangle " + std::to_string(t) + ", vertex " + std::to_string(k / 3) + ": non-finite coordinate (" +
                                     std::to_string(f[k]) + ")");
      }
    }
    pushSoupTriangle(soup, {f[0], f[1], f[2]}, {f[3], f[4], f[5]}, {f[6], f[7], f[8]});
  }
  return finishStl(std::move(soup), path, options, {});
}

// Whitespace-separated tokens with the line each starts on.
class Tokenizer {
 public:
  explicit Tokenizer(std::string_view s) : m_s(s) {}
  std::string_view next() {
    skipSpace();
    const std::size_t start = m_pos;
    while (m_pos < m_s.size() && !std::isspace(static_cast<unsigned char>(m_s[m_pos]))) ++m_pos;
    return m_s.substr(start, m_pos - start);
  }
  std::string_view restOfLine() {
    while (m_pos < m_s.size() && (m_s[m_pos] == ' ' || m_s[m_pos] == '\t')) ++m_pos;
    const std::size_t start = m_pos;
    while (m_pos < m_s.size() && m_s[m_pos] != '\n' && m_s[m_pos] != '\r') ++m_pos;
    std::string_view r = m_s.substr(start, m_pos - start);
    while (!r.empty() && std::isspace(static_cast<unsigned char>(r.back()))) r.remove_suffix(1);
    return r;
  }
  bool atEnd() {
    skipSpace();
    return m_pos >= m_s.size();
  }
  std::size_t line() const { return m_line; }

 private:
  void skipSpace() {
    while (m_pos < m_s.size() && std::isspace(static_cast<unsigned char>(m_s[m_pos]))) {
      if (m_s[m_pos] == '\n') ++m_line;
      ++m_pos;
    }
  }
  std::string_view m_s;
  std::size_t m_pos = 0;
  std::size_t m_line = 1;
};

std::string quoted(std::string_view t) {
  if (t.empty()) return "end of file";
  std::string s(t.substr(0, 40));
  for (char& c : s) {
    if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
  }
  return "'" + s + (t.size() > 40 ? "...'" : "'");
}

// Any number (non-finite and out-of-range included) filling the whole token.
bool isNumber(std::string_view tok) {
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (b != e && *b == '+') ++b;
  double v;
  const auto [p, ec] = std::from_chars(b, e, v);
  return b != e && (ec == std::errc() || ec == std::errc::result_out_of_range) && p == e;
}

// A decimal number that must fill the whole token; non-finite values are rejected with their own message.
Result<double> parseNumber(std::string_view tok, const char* what) {
  double v = 0;
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (!tok.empty() && *b == '+') ++b;  // from_chars does not take a leading '+', which files do use
  const auto [p, ec] = std::from_chars(b, e, v);
  if (ec == std::errc::result_out_of_range) return invalidArgument(std::string(what) + " " + quoted(tok) + " is out of range");
  if (ec != std::errc() || p != e) return invalidArgument("expected " + std::string(what) + ", got " + quoted(tok));
  if (!std::isfinite(v)) return invalidArgument(std::string(what) + " is not finite: " + quoted(tok));
  return v;
}

class AsciiStlParser {
 public:
  AsciiStlParser(std::string_view data, const std::string& path) : m_tok(data), m_path(path) {}

  struct Soup {
    TriMesh mesh;
    std::vector<std::size_t> lineOf;  // line of each facet
  };

  // Syntax only; finishStl() does the checks that do not depend on the format.
  Result<Soup> run() {
    TriMesh soup;
    std::vector<std::size_t> lineOf;
    while (!m_tok.atEnd()) {
      if (Status s = expect("solid"); !s) return s;
      const std::string_view name = m_tok.restOfLine();
      if (soup.surfaceNames.empty()) soup.surfaceNames = {name.empty() ? std::string("stl") : std::string(name)};
      for (;;) {
        const std::size_t line = nextLine();
        const std::string_view word = m_tok.next();
        if (word == "endsolid") {
          m_tok.restOfLine();
          break;
        }
        if (word != "facet") return error(line, "expected 'facet' or 'endsolid', got " + quoted(word));
        auto tri = facet();
        if (!tri) return tri.status();
        pushSoupTriangle(soup, (*tri)[0], (*tri)[1], (*tri)[2]);
        lineOf.push_back(line);
      }
    }
    if (soup.surfaceNames.empty()) soup.surfaceNames = {"stl"};
    return Soup{std::move(soup), std::move(lineOf)};
  }

 private:
  std::size_t nextLine() {
    m_tok.atEnd();  // skips whitespace so line() is the next token's line
    return m_tok.line();
  }
  Status error(std::size_t line, const std::string& what) const { return lineError(m_path, line, what); }
  Status expect(std::string_view word) {
    const std::size_t line = nextLine();
    const std::string_view got = m_tok.next();
    if (got == word) return Status::ok();
    return error(line, "expected '" + std::string(word) + "', got " + quoted(got));
  }
  Result<Vec3d> triple(const char* what) {
    double x[3];
    for (double& c : x) {
      const std::size_t line = nextLine();
      auto v = parseNumber(m_tok.next(), what);
      if (!v) return error(line, v.status().message());
      c = *v;
    }
    return Vec3d{x[0], x[1], x[2]};
  }
  // After 'facet': normal n n n, outer loop, 3 x vertex x y z, endloop, endfacet.
  Result<std::array<Vec3d, 3>> facet() {
    if (Status s = expect("normal"); !s) return s;
    // The stored normal is ignored (it is recomputed from the vertex order) but must be a number.
    for (int k = 0; k < 3; ++k) {
      const std::size_t line = nextLine();
      const std::string_view t = m_tok.next();
      if (!isNumber(t)) return error(line, "expected a normal component, got " + quoted(t));
    }
    if (Status s = expect("outer"); !s) return s;
    if (Status s = expect("loop"); !s) return s;
    std::array<Vec3d, 3> tri{};
    for (Vec3d& v : tri) {
      if (Status s = expect("vertex"); !s) {
        return Status(s.code(), s.message() + " (a facet needs exactly 3 vertices)");
      }
      auto p = triple("a vertex coordinate");
      if (!p) return p.status();
      v = *p;
    }
    if (Status s = expect("endloop"); !s) return Status(s.code(), s.message() + " (a facet needs exactly 3 vertices)");
    if (Status s = expect("endfacet"); !s) return s;
    return tri;
  }

  Tokenizer m_tok;
  const std::string& m_path;
};

bool startsWithSolid(std::string_view data) {
  std::size_t i = 0;
  while (i < data.size() && std::isspace(static_cast<unsigned char>(data[i]))) ++i;
  return data.substr(i, 5) == "solid" && (i + 5 == data.size() || std::isspace(static_cast<unsigned char>(data[i + 5])));
}

// --- OBJ --------------------------------------------------------------------------------------------------------------

bool isIgnoredObjStatement(std::string_view k) {
  static const std::set<std::string_view> kIgnored{"vt", "vn", "vp", "usemtl", "mtllib", "s", "l", "p", "mg", "lod",
                                                    "shadow_obj", "trace_obj", "bevel", "c_interp", "d_interp", "usemap",
                                                    "maplib", "ctech", "stech"};
  return kIgnored.count(k) > 0;
}

bool isFreeFormObjStatement(std::string_view k) {
  static const std::set<std::string_view> kFreeForm{"cstype", "deg", "bmat", "step", "curv", "curv2", "surf",
                                                     "parm", "trim", "hole", "scrv", "sp", "end", "con"};
  return kFreeForm.count(k) > 0;
}

std::vector<std::string_view> splitWords(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    const std::size_t start = i;
    while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i > start) out.push_back(s.substr(start, i - start));
  }
  return out;
}

class ObjParser {
 public:
  ObjParser(std::string_view data, const std::string& path) : m_data(data), m_path(path) {}

  Result<TriMesh> run(const MeshReadOptions& options) {
    std::size_t pos = 0, lineNo = 0;
    while (pos < m_data.size()) {
      // One logical line: physical lines joined where they end in a backslash.
      std::string joined;
      const std::size_t firstLine = lineNo + 1;
      for (;;) {
        std::size_t end = m_data.find('\n', pos);
        if (end == std::string_view::npos) end = m_data.size();
        std::string_view line = m_data.substr(pos, end - pos);
        pos = end + 1;
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (!line.empty() && line.back() == '\\' && pos < m_data.size()) {
          joined.append(line.substr(0, line.size() - 1)).push_back(' ');
          continue;
        }
        joined.append(line);
        break;
      }
      if (Status s = statement(joined, firstLine); !s) return s;
    }
    for (const PendingFace& f : m_faces) {
      for (std::int64_t v : f.corners) {
        if (v >= static_cast<std::int64_t>(m_mesh.vertices.size())) {
          return lineError(m_path, f.line, "face vertex index " + std::to_string(v + 1) + " is out of range (the file has " +
                                               std::to_string(m_mesh.vertices.size()) + " vertices)");
        }
      }
      // Fan from the first corner: exact for convex polygons, which is what exporters write.
      for (std::size_t k = 1; k + 1 < f.corners.size(); ++k) {
        m_mesh.triangles.push_back({static_cast<std::uint32_t>(f.corners[0]), static_cast<std::uint32_t>(f.corners[k]),
                                    static_cast<std::uint32_t>(f.corners[k + 1])});
        m_mesh.surface.push_back(f.surface);
        m_triangleLine.push_back(f.line);
      }
    }
    auto where = [&](std::size_t t) { return "triangle " + std::to_string(t) + " (face at line " + std::to_string(m_triangleLine[t]) + ")"; };
    if (Status s = finishMesh(m_mesh, m_path, options, where); !s) return s;
    return std::move(m_mesh);
  }

 private:
  struct PendingFace {
    std::vector<std::int64_t> corners;  // 0-based; range checked once every vertex is known
    std::int32_t surface;
    std::size_t line;
  };

  Status statement(std::string_view line, std::size_t lineNo) {
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    const std::vector<std::string_view> w = splitWords(line);
    if (w.empty()) return Status::ok();
    const std::string_view key = w[0];
    if (key == "v") return vertex(w, lineNo);
    if (key == "f") return face(w, lineNo);
    if (key == "o" || key == "g") {
      // The rest of the line, as written (a group line may list several names; they stay one name).
      const std::size_t start = static_cast<std::size_t>(w.size() > 1 ? w[1].data() - line.data() : line.size());
      std::string_view name = line.substr(start);
      while (!name.empty() && std::isspace(static_cast<unsigned char>(name.back()))) name.remove_suffix(1);
      m_surface = surfaceNamed(name.empty() ? "default" : std::string(name));
      return Status::ok();
    }
    if (isIgnoredObjStatement(key)) return Status::ok();
    if (isFreeFormObjStatement(key)) {
      return lineError(m_path, lineNo, "free-form geometry ('" + std::string(key) + "') is not supported; export the surface as triangles or polygons");
    }
    return lineError(m_path, lineNo, "unknown OBJ statement " + quoted(key));
  }

  Status vertex(const std::vector<std::string_view>& w, std::size_t lineNo) {
    if (w.size() < 4) return lineError(m_path, lineNo, "a vertex needs 3 coordinates, got " + std::to_string(w.size() - 1));
    double x[3];
    for (int k = 0; k < 3; ++k) {
      auto v = parseNumber(w[1 + k], "a vertex coordinate");
      if (!v) return lineError(m_path, lineNo, v.status().message());
      x[k] = *v;
    }
    m_mesh.vertices.push_back({x[0], x[1], x[2]});  // w and vertex colours, if any, are ignored
    return Status::ok();
  }

  Status face(const std::vector<std::string_view>& w, std::size_t lineNo) {
    if (w.size() < 4) return lineError(m_path, lineNo, "a face needs at least 3 vertices, got " + std::to_string(w.size() - 1));
    // Faces before any group go to an implicit "default" group, numbered only if it has faces.
    if (m_surface < 0) m_surface = surfaceNamed("default");
    PendingFace f{{}, m_surface, lineNo};
    for (std::size_t k = 1; k < w.size(); ++k) {
      // i, i/j, i//k, i/j/k: only the vertex index (before the first '/') matters here.
      const std::string_view ref = w[k].substr(0, w[k].find('/'));
      long long idx = 0;
      const auto [p, ec] = std::from_chars(ref.data(), ref.data() + ref.size(), idx);
      if (ref.empty() || ec != std::errc() || p != ref.data() + ref.size()) {
        return lineError(m_path, lineNo, "expected a vertex reference (i, i/j, i//k or i/j/k), got " + quoted(w[k]));
      }
      const auto count = static_cast<long long>(m_mesh.vertices.size());
      if (idx == 0) return lineError(m_path, lineNo, "vertex index 0 is invalid (OBJ indices start at 1)");
      if (idx < 0 && count + idx < 0) {
        return lineError(m_path, lineNo, "relative vertex index " + std::to_string(idx) + " is out of range (" + std::to_string(count) +
                                             " vertices defined so far)");
      }
      if (idx > static_cast<long long>(std::numeric_limits<std::uint32_t>::max())) {
        return lineError(m_path, lineNo, "vertex index " + std::to_string(idx) + " is out of range");
      }
      f.corners.push_back(idx > 0 ? idx - 1 : count + idx);
    }
    m_faces.push_back(std::move(f));
    return Status::ok();
  }

  // Surfaces are numbered in the order their names first appear, empty groups included, so a file
  // written by writeObj() keeps its numbers even where a surface has no triangles (an open face).
  std::int32_t surfaceNamed(const std::string& name) {
    const auto it = m_surfaceOf.find(name);
    if (it != m_surfaceOf.end()) return it->second;
    const auto id = static_cast<std::int32_t>(m_mesh.surfaceNames.size());
    m_mesh.surfaceNames.push_back(name);
    m_surfaceOf.emplace(name, id);
    return id;
  }

  std::string_view m_data;
  const std::string& m_path;
  TriMesh m_mesh;
  std::vector<PendingFace> m_faces;
  std::vector<std::size_t> m_triangleLine;
  std::int32_t m_surface = -1;  // of the current group; -1 before the first group
  std::map<std::string, std::int32_t> m_surfaceOf;
};

// --- writing ----------------------------------------------------------------------------------------------------------

// Shortest decimal that reads back as the same double.
void appendNumber(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void appendVec(std::string& out, const Vec3d& v) {
  appendNumber(out, v.x);
  out.push_back(' ');
  appendNumber(out, v.y);
  out.push_back(' ');
  appendNumber(out, v.z);
}

Vec3d unitNormal(const TriMesh& mesh, std::size_t t) {
  const Vec3d n = areaNormal(mesh, t);
  const double len = norm(n);
  return len > 0 ? (1.0 / len) * n : Vec3d{0, 0, 0};
}

Status writeWholeFile(const std::string& path, std::string_view data) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return fileError(path, std::string("cannot open for writing: ") + std::strerror(errno));
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  out.close();
  if (!out) return fileError(path, "write failed");
  return Status::ok();
}

Status checkWritable(const TriMesh& mesh, const std::string& path) {
  if (Status s = checkIndices(mesh); !s) return invalidArgument("cannot write '" + path + "': " + s.message());
  if (mesh.triangles.empty()) return invalidArgument("cannot write '" + path + "': the mesh has no triangles");
  return Status::ok();
}

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

Result<TriMesh> readStl(const std::string& path, const MeshReadOptions& options) {
  auto data = readWholeFile(path);
  if (!data) return data.status();
  const std::string_view d = *data;
  if (d.size() >= kStlHeader) {
    const std::uint32_t n = stlDeclaredCount(d);
    const std::uint64_t expected = kStlHeader + kStlRecord * static_cast<std::uint64_t>(n);
    if (d.size() == expected) {
      if (n == 0) return formatError(path, "binary STL with no triangles");
      return parseBinaryStl(d, path, options);
    }
    const std::string sizeNote = "header declares " + std::to_string(n) + " triangles, which needs " + std::to_string(expected) +
                                 " bytes, but the file has " + std::to_string(d.size()) + " bytes";
    if (!startsWithSolid(d)) return formatError(path, "truncated or corrupt binary STL: " + sizeNote);
    auto soup = AsciiStlParser(d, path).run();
    // Starts like ASCII but does not parse: it may equally be a damaged binary file; say both.
    if (!soup) return Status(soup.status().code(), soup.status().message() + " (not a binary STL either: " + sizeNote + ")");
    return finishStl(std::move(soup->mesh), path, options, std::move(soup->lineOf));
  }
  if (!startsWithSolid(d)) {
    return formatError(path, "not an STL file: " + std::to_string(d.size()) + " bytes is too short for binary STL (at least 84) and it does not start with 'solid'");
  }
  auto soup = AsciiStlParser(d, path).run();
  if (!soup) return soup.status();
  return finishStl(std::move(soup->mesh), path, options, std::move(soup->lineOf));
}

Result<TriMesh> readObj(const std::string& path, const MeshReadOptions& options) {
  auto data = readWholeFile(path);
  if (!data) return data.status();
  return ObjParser(*data, path).run(options);
}

Result<TriMesh> readMeshFile(const std::string& path, const MeshReadOptions& options) {
  const std::string ext = lowerExtension(path);
  if (ext == ".stl") return readStl(path, options);
  if (ext == ".obj") return readObj(path, options);
  return invalidArgument("'" + path + "': unsupported mesh file extension '" + ext + "' (expected .stl or .obj)");
}

Status writeStlBinary(const TriMesh& mesh, const std::string& path) {
  if (Status s = checkWritable(mesh, path); !s) return s;
  if (mesh.triangles.size() > std::numeric_limits<std::uint32_t>::max()) return invalidArgument("cannot write '" + path + "': too many triangles for STL");
  std::string out(kStlHeader + kStlRecord * mesh.triangles.size(), '\0');
  // The header must not begin with "solid", or readers that sniff the first bytes take it for ASCII.
  const std::string header = "pflow binary STL, SI units (m)";
  std::fill(out.begin(), out.begin() + 80, ' ');
  std::memcpy(out.data(), header.data(), header.size());
  const auto n = static_cast<std::uint32_t>(mesh.triangles.size());
  std::memcpy(out.data() + 80, &n, sizeof n);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Vec3d nn = unitNormal(mesh, t);
    float f[12] = {static_cast<float>(nn.x), static_cast<float>(nn.y), static_cast<float>(nn.z)};
    for (int c = 0; c < 3; ++c) {
      const Vec3d& v = mesh.vertices[mesh.triangles[t][c]];
      f[3 + 3 * c] = static_cast<float>(v.x);
      f[4 + 3 * c] = static_cast<float>(v.y);
      f[5 + 3 * c] = static_cast<float>(v.z);
    }
    std::memcpy(out.data() + kStlHeader + kStlRecord * t, f, sizeof f);  // attribute bytes stay 0
  }
  return writeWholeFile(path, out);
}

Status writeStlAscii(const TriMesh& mesh, const std::string& path, std::string_view solidName) {
  if (Status s = checkWritable(mesh, path); !s) return s;
  std::string out;
  out.reserve(256 * mesh.triangles.size() + 64);
  out.append("solid ").append(solidName).push_back('\n');
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    out.append("facet normal ");
    appendVec(out, unitNormal(mesh, t));
    out.append("\n outer loop\n");
    for (int c = 0; c < 3; ++c) {
      out.append("  vertex ");
      appendVec(out, mesh.vertices[mesh.triangles[t][c]]);
      out.push_back('\n');
    }
    out.append(" endloop\nendfacet\n");
  }
  out.append("endsolid ").append(solidName).push_back('\n');
  return writeWholeFile(path, out);
}

Status writeObj(const TriMesh& mesh, const std::string& path) {
  if (Status s = checkWritable(mesh, path); !s) return s;
  // Every surface number from 0 to the last named or used one gets a group, empty or not, in
  // ascending order; the reader numbers groups in order of appearance, so numbers survive.
  std::int32_t last = static_cast<std::int32_t>(mesh.surfaceNames.size()) - 1;
  for (std::int32_t s : mesh.surface) last = std::max(last, s);
  std::vector<std::vector<std::size_t>> bySurface(static_cast<std::size_t>(last + 1));
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (mesh.surface[t] < 0) return invalidArgument("cannot write '" + path + "': triangle " + std::to_string(t) + " has a negative surface number");
    bySurface[static_cast<std::size_t>(mesh.surface[t])].push_back(t);
  }
  // Group names must be unique, or the reader would merge two surfaces.
  std::set<std::string> used;
  auto groupName = [&](std::size_t s) {
    std::string name = s < mesh.surfaceNames.size() ? mesh.surfaceNames[s] : "";
    for (char& c : name) {
      if (c == '\n' || c == '\r' || c == '#' || c == '\\') c = '_';
    }
    if (name.empty() || used.count(name)) name = (name.empty() ? "surface" : name + "_") + std::to_string(s);
    used.insert(name);
    return name;
  };
  std::string out = "# pflow mesh: " + std::to_string(mesh.vertices.size()) + " vertices, " + std::to_string(mesh.triangles.size()) +
                    " triangles, SI units (m)\n";
  out.reserve(out.size() + 40 * mesh.vertices.size() + 30 * mesh.triangles.size());
  for (const Vec3d& v : mesh.vertices) {
    out.append("v ");
    appendVec(out, v);
    out.push_back('\n');
  }
  for (std::size_t s = 0; s < bySurface.size(); ++s) {
    out.append("g ").append(groupName(s)).push_back('\n');
    for (std::size_t t : bySurface[s]) {
      out.append("f ");
      for (int c = 0; c < 3; ++c) {
        out.append(std::to_string(mesh.triangles[t][c] + 1));
        out.push_back(c < 2 ? ' ' : '\n');
      }
    }
  }
  return writeWholeFile(path, out);
}

}  // namespace pflow::frontend
