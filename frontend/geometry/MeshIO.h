// Triangle mesh files: STL (binary and ASCII) and Wavefront OBJ, read into a TriMesh with shared
// vertices and written back. Coordinates are taken as metres as they stand (the scene applies any
// scale). docs/geometry.md describes what each format keeps.
//
// Reading never crashes on a bad file: every problem comes back as a Status whose message names the
// file and, where it applies, the line (text formats) or triangle (binary STL).
#pragma once
#include <string>
#include <string_view>

#include "common/Status.h"
#include "frontend/geometry/TriMesh.h"

namespace pflow::frontend {

struct MeshReadOptions {
  // Degenerate (zero-area) triangles are an error by default, since a wall triangle without a normal
  // cannot push a particle; set this to drop them instead (the count is lost, the mesh is kept).
  bool dropDegenerate = false;
};

// STL, binary or ASCII. Binary when the size is exactly 84 + 50 * (triangle count in the header),
// whatever the first bytes say (some binary files start with "solid"); otherwise ASCII, which must
// start with "solid". Vertices with bit-identical coordinates are welded, so neighbouring
// triangles share vertices. STL has no surfaces: every triangle is surface 0. The attribute bytes
// of binary STL are ignored.
Result<TriMesh> readStl(const std::string& path, const MeshReadOptions& options = {});

// Wavefront OBJ: `v` and `f` (i, i/j, i//k, i/j/k, negative = relative indices; polygons are
// fan-triangulated); `o`/`g` names become surfaces, numbered in order of first appearance (a group
// named twice is one surface; faces before any group form a surface "default").
// Texture/normal/material/smoothing lines are ignored; free-form geometry is an error.
Result<TriMesh> readObj(const std::string& path, const MeshReadOptions& options = {});

// By extension, case-insensitive: .stl or .obj.
Result<TriMesh> readMeshFile(const std::string& path, const MeshReadOptions& options = {});

// Binary STL (float32 coordinates, facet normals from the vertex order).
Status writeStlBinary(const TriMesh& mesh, const std::string& path);
// ASCII STL with shortest round-trip decimal coordinates (doubles read back exactly).
Status writeStlAscii(const TriMesh& mesh, const std::string& path, std::string_view solidName = "pflow");
// OBJ with each surface number 0..max as a `g` group (empty ones too, so numbers survive), named
// after surfaceNames (made unique; "surface<k>" when unnamed). Triangles are written grouped by
// surface, keeping their order within one, so a mesh whose triangles are in surface order reads
// back identical. Surface numbers must be >= 0.
Status writeObj(const TriMesh& mesh, const std::string& path);

}  // namespace pflow::frontend
