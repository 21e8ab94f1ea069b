// The initial state of a loaded scene in the snapshot layout (/snapshots/0, /geometry, XDMF sidecar): what
// `pflow build` writes and what the frontend service stores with every built model. No gRPC here.
#pragma once
#include <string>

#include "common/Status.h"
#include "frontend/SceneLoader.h"

namespace pflow::frontend {

// Writes `scene`'s particles (its output.fields, or all) and walls at t = 0 to `h5Path` (+ .xmf beside it).
Status writeInitialState(const LoadedScene& scene, const std::string& h5Path);

}  // namespace pflow::frontend
