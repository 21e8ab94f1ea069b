// The specs behind the committed example meshes (examples/meshes/), shared by the program that
// writes them (make_example_meshes) and the test that checks the committed files match.
#pragma once
#include "frontend/geometry/Primitives.h"

namespace pflow::frontend::examples {

// A small funnel: 20 mm orifice, 80 mm wide at the top, 40 mm cone + 30 mm cylinder; open at both
// ends. Default tessellation: 72 segments, 288 triangles. Outward normals (a solid's skin); a scene
// flips it to hold particles.
inline HopperSpec funnelSpec() { return {{0, 0, 0}, {0, 0, 1}, 0.01, 0.04, 0.04, 0.03, true, true}; }

// A 100 x 100 x 150 mm bin, top open, faces at most 50 mm per triangle edge: an OBJ with named groups.
inline BoxSpec binSpec() { return {{0, 0, 0}, {0.1, 0.1, 0.15}, {false, true, false, false, false, false}}; }
inline Tessellation binTessellation() { return Tessellation{.maxEdge = 0.05}; }

}  // namespace pflow::frontend::examples
