// Writes the example mesh files: make_example_meshes <dir>  (normally examples/meshes).
// mesh_io_test checks that the committed files are what this program writes.
#include <cstdio>
#include <string>

#include "frontend/geometry/MeshIO.h"
#include "tests/frontend/ExampleMeshes.h"

int main(int argc, char** argv) {
  using namespace pflow::frontend;
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <output directory>\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  auto funnel = tessellate(examples::funnelSpec());
  auto bin = tessellate(examples::binSpec(), examples::binTessellation());
  if (!funnel || !bin) {
    std::fprintf(stderr, "%s%s\n", funnel.status().message().c_str(), bin.status().message().c_str());
    return 1;
  }
  for (const pflow::Status& s : {writeStlBinary(*funnel, dir + "/funnel.stl"), writeObj(*bin, dir + "/bin.obj")}) {
    if (!s) {
      std::fprintf(stderr, "%s\n", s.message().c_str());
      return 1;
    }
  }
  std::printf("funnel.stl: %zu triangles; bin.obj: %zu triangles\n", funnel->size(), bin->size());
  return 0;
}
