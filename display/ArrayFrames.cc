#include "display/ArrayFrames.h"

#include <nlohmann/json.hpp>

#include <algorithm>

#include "common/Log.h"

namespace pflow::display {
namespace {

using nlohmann::json;

void appendFrame(std::string& out, const json& header, const std::vector<float>* values) {
  const std::string h = header.dump(-1, ' ', false, json::error_handler_t::replace);
  const auto n = static_cast<std::uint32_t>(h.size());
  char len[4];
  for (int i = 0; i < 4; ++i) len[i] = char((n >> (8 * i)) & 0xff);
  out.append(len, 4);
  out += h;
  // float32 little-endian: the byte order of every host pflow builds for (x86-64, aarch64).
  if (values) out.append(reinterpret_cast<const char*>(values->data()), values->size() * sizeof(float));
}

}  // namespace

void appendHeaderFrame(std::string& out, std::int64_t step, double time) { appendFrame(out, {{"step", step}, {"time", time}}, nullptr); }

void appendPieceFrame(std::string& out, const ArrayPiece& p) {
  if (!p.strings.empty()) {
    appendFrame(out, {{"section", p.section}, {"name", p.name}, {"strings", p.strings}}, nullptr);
    return;
  }
  json h = {{"section", p.section}, {"name", p.name}, {"first_row", p.firstRow}, {"rows", p.rows}, {"total_rows", p.totalRows},
            {"components", p.components}, {"unit", p.unit}};
  if (p.grid)
    h["grid"] = {{"origin", {p.grid->origin[0], p.grid->origin[1], p.grid->origin[2]}},
                 {"cell_size", p.grid->cellSize},
                 {"cells", {p.grid->cells[0], p.grid->cells[1], p.grid->cells[2]}}};
  appendFrame(out, h, &p.values);
}

void appendErrorFrame(std::string& out, const Status& s) {
  appendFrame(out, {{"error", log::escaped(s.message(), 2000)}, {"code", statusCodeName(s.code())}}, nullptr);
}

std::uint64_t rowsPerPiece(std::uint64_t components) {
  return std::max<std::uint64_t>(1, (std::uint64_t(1) << 20) / (sizeof(float) * std::max<std::uint64_t>(1, components)));
}

}  // namespace pflow::display
