#include "backend/store/SnapshotXdmf.h"

#include <charconv>
#include <sstream>
#include <string_view>

#include "backend/store/Hdf5Detail.h"

namespace pflow::backend::detail {
namespace {

struct XdmfNumber {
  const char* type;
  int precision;
};

XdmfNumber xdmfNumberOf(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: return {"Float", 8};
    case ScalarType::kF32: return {"Float", 4};
    case ScalarType::kI32: return {"Int", 4};
    case ScalarType::kU64: return {"UInt", 8};
    case ScalarType::kU32: return {"UInt", 4};
    case ScalarType::kI8: return {"Char", 1};
  }
  return {"Float", 8};
}

const char* xdmfAttributeType(int components) {
  switch (components) {
    case 1: return "Scalar";
    case 3: return "Vector";
    case 6: return "Tensor6";
    case 9: return "Tensor";
    default: return "Matrix";
  }
}

// --- XDMF sidecar -----------------------------------------------------------------------------------------------

std::string xmlEscape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// Shortest text that reads back as the same double.
std::string formatDouble(double v) {
  char buf[64];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, ptr) : std::to_string(v);
}

class XdmfBuilder {
 public:
  explicit XdmfBuilder(std::string h5Name) : m_h5(xmlEscape(h5Name)) {}

  std::string build(const std::map<std::int64_t, GridInfo>& grids, const std::optional<GeometryInfo>& geometry,
                    hsize_t indexSize) {
    const bool withGeometry = geometry && geometry->drawable();
    m_os << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
         << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
         << "  <Domain>\n";
    if (!grids.empty()) {
      m_os << "    <Grid Name=\"pflow\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
      for (const auto& [step, grid] : grids) {
        if (withGeometry) {
          m_os << "      <Grid Name=\"step " << step << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
               << "        <Time Value=\"" << formatDouble(grid.time) << "\"/>\n";
          particles(grid, indexSize, false, 8);
          geometryGrid(*geometry, 8);
          m_os << "      </Grid>\n";
        } else {
          particles(grid, indexSize, true, 6);
        }
      }
      m_os << "    </Grid>\n";
    } else if (withGeometry) {
      geometryGrid(*geometry, 4);
    }
    m_os << "  </Domain>\n"
         << "</Xdmf>\n";
    return m_os.str();
  }

 private:
  void dataItem(int indent, const std::string& dims, XdmfNumber num, const std::string& h5Path) {
    m_os << pad(indent) << "<DataItem Dimensions=\"" << dims << "\" NumberType=\"" << num.type << "\" Precision=\""
         << num.precision << "\" Format=\"HDF\">" << m_h5 << ':' << xmlEscape(h5Path) << "</DataItem>\n";
  }

  static std::string dims(std::size_t rows, int cols) {
    return cols == 1 ? std::to_string(rows) : std::to_string(rows) + " " + std::to_string(cols);
  }

  static std::string pad(int n) { return std::string(static_cast<std::size_t>(n), ' '); }

  void particles(const GridInfo& g, hsize_t indexSize, bool withTime, int in) {
    const std::string group = stepGroupPath(g.step);
    m_os << pad(in) << "<Grid Name=\"particles\" GridType=\"Uniform\">\n";
    if (withTime) m_os << pad(in + 2) << "<Time Value=\"" << formatDouble(g.time) << "\"/>\n";
    if (g.n == 0) {
      // No vertex cells to select (and maybe no index dataset yet); the zero-length datasets are still referenced,
      // which ParaView's XDMF3 readers accept (an inline empty XML DataItem makes them abort).
      m_os << pad(in + 2) << "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"0\" NodesPerElement=\"1\"/>\n";
    } else {
      // One vertex cell per particle: the first n entries of the shared 0..M-1 index dataset. Without explicit
      // connectivity the XDMF3 readers make points but no cells, and ParaView draws nothing.
      m_os << pad(in + 2) << "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << g.n
           << "\" NodesPerElement=\"1\">\n"
           << pad(in + 4) << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << g.n
           << "\" NumberType=\"UInt\" Precision=\"4\" Type=\"HyperSlab\">\n"
           << pad(in + 6) << "<DataItem Dimensions=\"3 1\" NumberType=\"UInt\" Precision=\"4\" Format=\"XML\">0 1 "
           << g.n << "</DataItem>\n";
      dataItem(in + 6, std::to_string(indexSize), {"UInt", 4}, kIndexDataset);
      m_os << pad(in + 4) << "</DataItem>\n" << pad(in + 2) << "</Topology>\n";
    }
    for (const auto& a : g.arrays) {
      if (a.name != kPositionName) continue;
      m_os << pad(in + 2) << "<Geometry GeometryType=\"XYZ\">\n";
      dataItem(in + 4, dims(g.n, 3), xdmfNumberOf(a.type), group + "/" + a.name);
      m_os << pad(in + 2) << "</Geometry>\n";
    }
    for (const auto& a : g.arrays) {
      if (a.name == kPositionName) continue;
      m_os << pad(in + 2) << "<Attribute Name=\"" << xmlEscape(a.name) << "\" AttributeType=\""
           << xdmfAttributeType(a.components) << "\" Center=\"Node\">\n";
      dataItem(in + 4, dims(g.n, a.components), xdmfNumberOf(a.type), group + "/" + a.name);
      m_os << pad(in + 2) << "</Attribute>\n";
    }
    m_os << pad(in) << "</Grid>\n";
  }

  void geometryGrid(const GeometryInfo& g, int in) {
    const std::string group = kGeometryGroup;
    m_os << pad(in) << "<Grid Name=\"geometry\" GridType=\"Uniform\">\n"
         << pad(in + 2) << "<Topology TopologyType=\"Triangle\" NumberOfElements=\"" << g.triangles
         << "\" NodesPerElement=\"3\">\n";
    dataItem(in + 4, dims(g.triangles, 3), {"UInt", 4}, group + "/triangles");
    m_os << pad(in + 2) << "</Topology>\n" << pad(in + 2) << "<Geometry GeometryType=\"XYZ\">\n";
    dataItem(in + 4, dims(g.vertices, 3), {"Float", 8}, group + "/vertices");
    m_os << pad(in + 2) << "</Geometry>\n";
    auto cellAttribute = [&](bool present, const char* name) {
      if (!present) return;
      m_os << pad(in + 2) << "<Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Cell\">\n";
      dataItem(in + 4, dims(g.triangles, 1), {"Int", 4}, group + "/" + name);
      m_os << pad(in + 2) << "</Attribute>\n";
    };
    cellAttribute(g.surface, "triangle_surface");
    cellAttribute(g.mesh, "triangle_mesh");
    cellAttribute(g.material, "triangle_material");
    m_os << pad(in) << "</Grid>\n";
  }

  std::string m_h5;
  std::ostringstream m_os;
};

}  // namespace

std::string buildXdmf(const std::string& h5Name, const std::map<std::int64_t, GridInfo>& grids,
                      const std::optional<GeometryInfo>& geometry, std::uint64_t indexSize) {
  return XdmfBuilder(h5Name).build(grids, geometry, hsize_t(indexSize));
}

}  // namespace pflow::backend::detail
