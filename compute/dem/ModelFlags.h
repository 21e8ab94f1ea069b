// What the engine computes (EngineSetup::model), chosen by deriveModel (ModelChoice.h). The defaults are
// the full model. Kept apart from ModelChoice.h so the engine's headers (nvcc) need nothing else.
#pragma once

namespace pflow::compute {

struct ModelFlags {
  int planarAxis = -1;     // 0, 1, 2: discs in the plane normal to that axis (2D); -1: 3D
  bool tangential = true;  // tangential forces and their history slots (particle and wall)
  bool rolling = true;     // rolling-resistance torque
  bool walls = true;       // the wall phases (wall candidates at rebuild, wall forces)
  bool cohesion = false;   // a material pair has adhesion (pairs[].cohesion); implies tangential (its slots)
};

}  // namespace pflow::compute
