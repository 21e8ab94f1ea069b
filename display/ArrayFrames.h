// application/x-pflow-arrays (docs/viewer.md), the compact binary form in which pflow-web and `pflow render` hand
// snapshot arrays to the page: frames of a little-endian u32 n, n bytes of JSON, then the frame's values as
// little-endian float32. First {"step", "time"}; then one frame per piece of an array
// {"section", "name", "first_row", "rows", "total_rows", "components", "unit"[, "grid": {"origin", "cell_size",
// "cells"}]} with rows x components values, or a list of names {"section", "name", "strings": [...]} with none;
// an error ends a stream with {"error", "code"}.
#pragma once
#include <cstdint>
#include <string>

#include "common/Status.h"
#include "display/ViewerSources.h"

namespace pflow::display {

void appendHeaderFrame(std::string& out, std::int64_t step, double time);
void appendPieceFrame(std::string& out, const ArrayPiece& piece);
void appendErrorFrame(std::string& out, const Status& error);

// Values per piece so that one piece holds at most 1 MiB of float32 (at least one row).
std::uint64_t rowsPerPiece(std::uint64_t components);

}  // namespace pflow::display
