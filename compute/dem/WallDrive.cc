#include "compute/dem/WallDrive.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace pflow::compute {

namespace {
// A drive that holds a target speed u0 with at most `limit` (one coordinate: along the guide, or about the axis), given
// the inertia m, the load f and the speed u a half step before the step's end. Where the force that brings u to u0
// by the step's end is within the limit, the drive holds: the second half kick (u += dt/2 a) lands on u0, and the
// acceleration left for the next step's first half kick is 0 (the drive keeps cancelling the load; carrying the
// correction over instead would make the drive ring, bang-bang, from one step to the next). Beyond the limit the
// drive pushes at it and the wall moves by Newton's law.
void hold(double m, double f, double u0, double limit, double dt, double u, double& a, double& drive) {
  const double needed = m * (u0 - u) / (0.5 * dt) - f;
  drive = std::clamp(needed, -limit, limit);
  a = (f + drive) / m;
}

}  // namespace


Result<WallDrives> WallDrives::create(const RunConfig& c, const EngineSetup& setup) {
  WallDrives d;
  for (std::size_t m = 0; m < c.meshes.size(); ++m) {
    const MeshConfig& mc = c.meshes[m];
    if (!mc.motion.drive) continue;
    Wall w;
    w.mesh = int(m);
    w.name = mc.name;
    w.drive = *mc.motion.drive;
    w.base = setup.meshMotion[m];
    w.startTime = mc.motion.startTime;
    if (w.drive.translates()) {
      const Vec3d along = norm2(w.drive.force) > 0 ? w.drive.force : mc.motion.velocity;
      w.direction = (1.0 / norm(along)) * along;
      w.targetSpeed = norm(mc.motion.velocity);
    }
    w.targetOmega = mc.motion.angularSpeed;
    std::set<int> own;
    for (std::size_t t = 0; t < setup.triMesh.size(); ++t)
      if (setup.triMesh[t] == int(m)) own.insert(setup.triSurface[t]);
    for (std::size_t t = 0; t < setup.triMesh.size(); ++t)
      if (setup.triMesh[t] != int(m) && own.count(setup.triSurface[t]))
        return Status(StatusCode::kInvalidArgument, "meshes[" + std::to_string(m) + "].motion.drive: the wall '" + mc.name +
                                                        "' shares a surface number with mesh '" + c.meshes[std::size_t(setup.triMesh[t])].name +
                                                        "': a driven wall needs surfaces of its own (its load moves it)");
    for (std::int32_t s : setup.planeSurface)
      if (own.count(s))
        return Status(StatusCode::kInvalidArgument, "meshes[" + std::to_string(m) + "].motion.drive: the wall '" + mc.name +
                                                        "' shares a surface number with a plane: a driven wall needs surfaces of its own");
    w.surfaces.assign(own.begin(), own.end());
    d.m_walls.push_back(std::move(w));
  }
  return d;
}

MeshMotionParams WallDrives::paramsAt(const Wall& w, double t, double speed, double omega) const {
  MeshMotionParams p = w.base;
  p.startTime = t;
  p.offset = w.s * w.direction;
  p.angle0 = w.theta;
  p.velocity = speed * w.direction;
  p.angularSpeed = omega;
  return p;
}

void WallDrives::beginStep(double t, double dt, Engine& engine) {
  for (Wall& w : m_walls) {
    if (t + dt <= w.startTime) continue;  // held still until the drive starts
    const double vHalf = w.v + 0.5 * dt * w.a, wHalf = w.omega + 0.5 * dt * w.alpha;
    engine.setMeshMotion(w.mesh, paramsAt(w, t, vHalf, wHalf));  // from where it is, at the half-step velocity
    w.s += dt * vHalf;
    w.theta += dt * wHalf;
    w.v = vHalf;
    w.omega = wHalf;
  }
}

void WallDrives::start(const std::vector<double>& loads, double t0, double dt) {
  for (Wall& w : m_walls)
    if (t0 >= w.startTime) accelerate(w, loads, dt);
}

void WallDrives::endStep(const std::vector<double>& loads, double tNext, double dt) {
  for (Wall& w : m_walls) {
    if (tNext <= w.startTime) continue;
    accelerate(w, loads, dt);
    const bool holdsTranslation = w.drive.forceLimit > 0 && std::fabs(w.driveForce) < w.drive.forceLimit;
    const bool holdsRotation = w.drive.torqueLimit > 0 && std::fabs(w.driveTorque) < w.drive.torqueLimit;
    w.v += 0.5 * dt * w.a;
    w.omega += 0.5 * dt * w.alpha;
    if (holdsTranslation) w.v = w.targetSpeed, w.a = 0;  // held: exactly the target, nothing carried over
    if (holdsRotation) w.omega = w.targetOmega, w.alpha = 0;
  }
}

void WallDrives::accelerate(Wall& w, const std::vector<double>& loads, double dt) {
  Vec3d force{0, 0, 0}, torque{0, 0, 0};  // on the wall; torque about the origin
  for (int s : w.surfaces) {
    if (std::size_t(6 * s + 5) >= loads.size()) continue;
    force = force + Vec3d{loads[6 * s], loads[6 * s + 1], loads[6 * s + 2]};
    torque = torque + Vec3d{loads[6 * s + 3], loads[6 * s + 4], loads[6 * s + 5]};
  }
  if (w.drive.translates()) {
    // The drive holds the target speed where it can: the force that brings v to it over the half step, clamped.
    const double f = dot(force, w.direction), m = w.drive.mass;
    w.contactForce = f;
    w.driveForce = norm(w.drive.force);
    w.a = (f + w.driveForce) / m;
    if (w.drive.forceLimit > 0) hold(m, f, w.targetSpeed, w.drive.forceLimit, dt, w.v, w.a, w.driveForce);
  }
  if (w.drive.rotates()) {
    // The torque about the axis through its point, where the translation has carried it.
    const Vec3d p = w.base.axisPoint + w.s * w.direction;
    const double tq = dot(torque - cross(p, force), w.base.axis), inertia = w.drive.inertia;
    w.contactTorque = tq;
    w.driveTorque = w.drive.torque;
    w.alpha = (tq + w.driveTorque) / inertia;
    if (w.drive.torqueLimit > 0) hold(inertia, tq, w.targetOmega, w.drive.torqueLimit, dt, w.omega, w.alpha, w.driveTorque);
  }
}

std::vector<double> WallDrives::state() const {
  std::vector<double> out;
  for (const Wall& w : m_walls) out.insert(out.end(), {w.s, w.v, w.a, w.theta, w.omega, w.alpha});
  return out;
}

Status WallDrives::restore(const std::vector<double>& values, double t, Engine& engine) {
  if (values.size() != kStateValues * m_walls.size())
    return Status(StatusCode::kInvalidArgument, "the checkpoint holds the state of " + std::to_string(values.size() / kStateValues) +
                                                    " driven wall(s), the scene has " + std::to_string(m_walls.size()));
  for (std::size_t k = 0; k < m_walls.size(); ++k) {
    Wall& w = m_walls[k];
    const double* v = values.data() + kStateValues * k;
    w.s = v[0], w.v = v[1], w.a = v[2], w.theta = v[3], w.omega = v[4], w.alpha = v[5];
    engine.setMeshMotion(w.mesh, paramsAt(w, t, 0.0, 0.0));  // where it is; the next step moves it on
  }
  return Status::ok();
}

}  // namespace pflow::compute
