// pflow-model-bench: what the least model (simulation.model: auto, compute/dem/ModelChoice.h) saves against
// the full model, on beds where each simplification applies. One JSON line per run on stdout.
//   frictionless  the standard settled bed (bench/BedScene.h) with friction 0: no tangential history
//   norolling     the standard bed as it is (friction 0.5, no rolling friction): no rolling torque
//   planar        the standard bed one lattice layer thick (discs in the x-z plane, no y walls, the domain
//                 derived), rolling friction 0.01: 2D
//   nowalls       the standard bed without its walls and gravity, spheres flying apart and colliding, rolling
//                 friction 0.01: no wall phases
//   adhesive      the standard bed with adhesion among the beads and with the walls (--adhesion jkr or constant,
//                 --work-of-adhesion 0.1 J/m^2: JKR's pull-off about 9 times a bead's weight): the cost of adhesion,
//                 against norolling's auto row
// (frictionless also has no rolling friction, so its least model drops the rolling torque too.)
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bench/BedScene.h"
#include "common/Log.h"
#include "compute/dem/ModelChoice.h"
#include "compute/dem/Simulation.h"

namespace {

using pflow::compute::RunConfig;

struct Adhesion {
  pflow::compute::CohesionModel model = pflow::compute::CohesionModel::kJkr;
  double workOfAdhesion = 0.1;  // [J/m^2]
};

RunConfig caseScene(const std::string& name, long n, int threads, const Adhesion& adhesion) {
  pflow::bench::BedSpec spec = pflow::bench::bedSpecFor(n, false);
  if (name == "planar") {
    spec.ny = 1;
    spec.nx = int(std::max(1L, n / spec.nz));
  }
  spec.threads = threads;
  RunConfig c = pflow::bench::bedScene(spec);
  if (name == "frictionless") {
    for (auto& m : c.materials) m.friction = 0;
  } else if (name == "planar") {
    for (auto& m : c.materials) m.rollingFriction = 0.01;  // so that 2D is the only simplification
    // One layer of discs: every centre at the middle of the box in y, no walls normal to y.
    double y = 0;
    for (const auto& x : c.particles.position) y += x.y / double(c.particles.size());
    for (auto& x : c.particles.position) x.y = y;
    std::vector<pflow::compute::PlaneConfig> keep;
    for (const auto& p : c.planes)
      if (p.normal.y == 0) keep.push_back(p);
    c.planes = keep;
    for (auto& v : c.particles.velocity) v.y = 0;
    c.particles.angularVelocity.assign(c.particles.size(), {0, 0, 0});
    // The domain derived around them (as a scene without `domain` gets it): several cells deep in y in 3D.
    c.sim.domain.reset();
  } else if (name == "nowalls") {
    for (auto& m : c.materials) m.rollingFriction = 0.01;  // so that the wall phases are the only simplification
    c.planes.clear();
    c.sim.gravity = {0, 0, 0};
    c.sim.domain.reset();  // derived from where the particles are (they fly out of the bed's box)
    // Each sphere moving away from the bed's centre at up to 0.1 m/s: a cloud that expands and collides.
    pflow::Vec3d centre{0, 0, 0};
    for (const auto& x : c.particles.position) centre = centre + (1.0 / double(c.particles.size())) * x;
    c.particles.velocity.resize(c.particles.size());
    for (std::size_t i = 0; i < c.particles.size(); ++i) {
      const pflow::Vec3d d = c.particles.position[i] - centre;
      c.particles.velocity[i] = (0.1 / (pflow::norm(d) + 1e-3)) * d;
    }
  } else if (name == "adhesive") {
    pflow::compute::MaterialPairConfig pair;  // material 0 is the beads' and the walls'
    pair.cohesion = adhesion.model;
    pair.workOfAdhesion = adhesion.workOfAdhesion;
    c.pairs = {pair};
  }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pflow-model-bench: least model against full model"};
  std::vector<std::string> cases{"frictionless", "norolling", "planar", "nowalls", "adhesive"};
  std::vector<std::string> models{"full", "auto"};
  long n = 20000;
  int settle = 20000, warm = 50, steps = 1000, threads = 0, repeats = 1;
  std::string executor = "cpu", precision = "double";
  app.add_option("--case", cases, "frictionless, norolling, planar, nowalls, adhesive (comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"frictionless", "norolling", "planar", "nowalls", "adhesive"}));
  app.add_option("--model", models, "full, auto, or both (comma-separated)")->delimiter(',')->check(CLI::IsMember({"full", "auto"}));
  app.add_option("-n,--particles", n, "particles (about)")->capture_default_str();
  std::string adhesionModel = "jkr";
  Adhesion adhesion;
  app.add_option("--adhesion", adhesionModel, "the adhesive case's model: jkr or constant")
      ->check(CLI::IsMember({"jkr", "constant"}))
      ->capture_default_str();
  app.add_option("--work-of-adhesion", adhesion.workOfAdhesion, "the adhesive case's work of adhesion [J/m^2]")->capture_default_str();
  app.add_option("--settle-steps", settle, "steps that settle each case's bed once, before any timing")->capture_default_str();
  app.add_option("--warm-steps", warm, "untimed steps of each timed run (history and lists refill)")->capture_default_str();
  app.add_option("--steps", steps, "timed steps")->capture_default_str();
  app.add_option("--repeats", repeats, "timed runs of each case and model (the fastest is reported)")->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads (0: all cores)");
  app.add_option("--executor", executor, "cpu, cuda or auto")->capture_default_str();
  app.add_option("--precision", precision, "double or float")->check(CLI::IsMember({"double", "float"}))->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (adhesionModel == "constant") adhesion.model = pflow::compute::CohesionModel::kConstant;
  pflow::log::init("pflow-model-bench", "warn");
  auto kind = pflow::compute::parseExecutorKind(executor);
  if (!kind) {
    std::fprintf(stderr, "%s\n", kind.status().toString().c_str());
    return 1;
  }
  pflow::compute::SimulationOptions so;
  so.executor = kind.value();
  for (const auto& name : cases) {
    // Settled once (least model), then every model is timed from that state (history starts empty and
    // rebuilds within a few steps).
    RunConfig settled = caseScene(name, n, threads, adhesion);
    {
      auto sim = pflow::compute::Simulation::create(settled, so);
      if (!sim) {
        std::fprintf(stderr, "%s\n", sim.status().toString().c_str());
        return 1;
      }
      if (auto s = sim.value()->runSteps(settle); !s.isOk()) {
        std::fprintf(stderr, "%s: %s\n", name.c_str(), s.toString().c_str());
        return 1;
      }
      settled = pflow::bench::withState(std::move(settled), sim.value()->snapshot());
    }
    for (const auto& model : models) {
      RunConfig c = settled;
      c.sim.model = model == "full" ? pflow::compute::ModelMode::kFull : pflow::compute::ModelMode::kAuto;
      c.sim.precision = precision == "float" ? pflow::compute::Precision::kFloat : pflow::compute::Precision::kDouble;
      c.sim.precisionGiven = true;
      const pflow::compute::ModelChoice choice = pflow::compute::deriveModel(c);
      double best = 1e300;
      nlohmann::json phases;
      std::int64_t rebuilds = 0;
      std::size_t particles = 0;
      for (int r = 0; r < repeats; ++r) {
        auto sim = pflow::compute::Simulation::create(c, so);
        if (!sim) {
          std::fprintf(stderr, "%s\n", sim.status().toString().c_str());
          return 1;
        }
        if (auto s = sim.value()->runSteps(warm); !s.isOk()) {
          std::fprintf(stderr, "%s: %s\n", name.c_str(), s.toString().c_str());
          return 1;
        }
        sim.value()->timers().reset();
        const std::int64_t rebuilds0 = sim.value()->rebuilds();
        const auto t0 = std::chrono::steady_clock::now();
        if (auto s = sim.value()->runSteps(steps); !s.isOk()) {
          std::fprintf(stderr, "%s: %s\n", name.c_str(), s.toString().c_str());
          return 1;
        }
        sim.value()->engine().fence();
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (wall < best) {
          best = wall;
          phases = nlohmann::json::object();
          for (int p = 0; p < int(pflow::compute::Phase::kCount); ++p)
            phases[pflow::compute::kPhaseNames[p]] = sim.value()->timers().seconds(pflow::compute::Phase(p));
          rebuilds = sim.value()->rebuilds() - rebuilds0;
          particles = sim.value()->numParticles();
        }
      }
      const nlohmann::json j{{"case", name},
                             {"model", model},
                             {"flags", {{"planar_axis", choice.flags.planarAxis}, {"tangential", choice.flags.tangential},
                                        {"rolling", choice.flags.rolling}, {"walls", choice.flags.walls},
                                        {"cohesion", choice.flags.cohesion}}},
                             {"adhesion", name == "adhesive" ? adhesionModel : std::string("none")},
                             {"executor", executor},
                             {"precision", precision},
                             {"particles", particles},
                             {"steps", steps},
                             {"rebuilds", rebuilds},
                             {"wall_s", best},
                             {"particle_steps_per_s", double(particles) * steps / best},
                             {"phases_s", phases}};
      std::printf("%s\n", j.dump().c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}
