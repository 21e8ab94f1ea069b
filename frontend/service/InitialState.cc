#include "frontend/service/InitialState.h"

#include <algorithm>
#include <filesystem>

#include "backend/store/SnapshotFile.h"
#include "compute/dem/Simulation.h"
#include "compute/sph/SphSimulation.h"

namespace pflow::frontend {

Status writeInitialState(const LoadedScene& scene, const std::string& h5Path) {
  if (const auto parent = std::filesystem::path(h5Path).parent_path(); !parent.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(parent, ec);
    if (ec) return ioError("cannot create the folder '" + parent.string() + "': " + ec.message());
  }
  if (scene.config.solver == compute::Solver::kSph) {  // the hydrostatic initial densities and pressures, on the CPU
    auto sph = compute::sph::SphSimulation::create(scene.config, {});
    if (!sph) return sph.status();
    auto writer = backend::SnapshotWriter::create(h5Path);
    if (!writer) return writer.status();
    if (Status s = writer.value()->writeSnapshot(sph.value()->snapshot(scene.outputFields)); !s.isOk()) return s;
    return writer.value()->close();
  }
  compute::SimulationOptions options;
  auto sim = compute::Simulation::create(scene.config, options);
  if (!sim) return sim.status();
  auto writer = backend::SnapshotWriter::create(h5Path);
  if (!writer) return writer.status();
  if (Status s = writer.value()->writeGeometry(sim.value()->geometry()); !s.isOk()) return s;
  if (Status s = writer.value()->writeSnapshot(sim.value()->snapshot(scene.outputFields)); !s.isOk()) return s;
  return writer.value()->close();
}

}  // namespace pflow::frontend
