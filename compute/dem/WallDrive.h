// Walls driven by a force or a torque (motion.drive in the scene; RunConfig's MeshMotion::Drive): a mesh that is a
// rigid body on a guide, moved each step by Newton's law under the particles' contact forces and its drive, with
// the particles' velocity-Verlet step (half kick, drift, forces, half kick). Translation along one direction: a
// constant force, or a drive that holds a velocity while that takes at most a force limit (a press, a piston at
// constant pressure, a plate pushed until it meets its load). Rotation about a fixed axis: a constant torque, or a
// motor that holds an angular velocity up to a torque limit (a drum whose motor stalls). The contact loads come from
// the wall loads of the driven mesh's surfaces, summed over ranks, every step. Host only (a few doubles per wall).
#pragma once
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/dem/Engine.h"
#include "compute/sim/RunConfig.h"

namespace pflow::compute {

class WallDrives {
 public:
  // One driven wall and its state; `s`, `v` along the guide (the unit `direction`), `theta`, `omega` about `axis`.
  struct Wall {
    int mesh = 0;
    std::string name;
    MeshMotion::Drive drive;
    MeshMotionParams base;          // the mesh's motion parameters (axis point, axis), held still
    Vec3d direction{0, 0, 1};       // the guide (unit)
    double targetSpeed = 0;         // along the guide, with a force limit [m/s]
    double targetOmega = 0;         // about the axis, with a torque limit [rad/s]
    double startTime = 0;
    std::vector<int> surfaces;      // the mesh's surface numbers
    double s = 0, v = 0, a = 0;              // displacement [m], velocity [m/s], acceleration [m/s^2]
    double theta = 0, omega = 0, alpha = 0;  // angle [rad], angular velocity [rad/s], acceleration [rad/s^2]
    double driveForce = 0, driveTorque = 0;  // what the drive applied at the last step [N], [N m]
    double contactForce = 0, contactTorque = 0;  // the particles' load along the guide / about the axis
  };
  static constexpr int kStateValues = 6;  // per wall in state(): s, v, a, theta, omega, alpha

  // The driven meshes of `c` (validated); `setup` is the engine setup prepareEngineSetup made from it (its mesh
  // motion for a driven mesh is held still: the drive moves it). Fails when a driven mesh shares a surface number
  // with another wall (its load would not be its own).
  static Result<WallDrives> create(const RunConfig& c, const EngineSetup& setup);

  bool empty() const { return m_walls.empty(); }
  const std::vector<Wall>& walls() const { return m_walls; }

  // At the run's start (after the first forces, at time t0 with the step dt): each wall's acceleration from its loads
  // and drive, as the particles' first half kick takes theirs from the first forces.
  void start(const std::vector<double>& loads, double t0, double dt);
  // Before the meshes move to t + dt: each wall's first half kick and drift, and its motion over the step given to
  // the engine (the wall's velocity over the step is the half-step one, as the particles' is).
  void beginStep(double t, double dt, Engine& engine);
  // After the forces at t + dt: the walls' loads (6 per surface number, Engine::wallLoads, summed over ranks), the
  // drives, the second half kick.
  void endStep(const std::vector<double>& loads, double tNext, double dt);

  // The walls' state for a checkpoint (kStateValues per wall, in order), and back: the engine's mesh motion set to
  // hold each wall where the state has it at time t.
  std::vector<double> state() const;
  Status restore(const std::vector<double>& values, double t, Engine& engine);

 private:
  MeshMotionParams paramsAt(const Wall& w, double t, double speed, double omega) const;
  // The drive and the acceleration of w from the loads at time t (v, omega as they are then).
  void accelerate(Wall& w, const std::vector<double>& loads, double dt);
  std::vector<Wall> m_walls;
};

}  // namespace pflow::compute
