#include "frontend/SceneSummary.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <numbers>

#include "compute/dem/ParticleFields.h"
#include "compute/dem/Simulation.h"
#include "compute/dem/TimeStep.h"

namespace pflow::frontend {

namespace {

// Device bytes per particle on the GPU: every field of the table at the run's precision (slot fields times
// their initial slot count), the reorder scratch (one column of the widest field: slot fields are
// slot-major there), the displacement since rebuild, cell key and permutation, and neighbour rows of about
// 16 candidates of an index and a history slot each, plus the wall-candidate rows. An estimate: slots and
// rows grow on demand (docs/performance.md, "Memory per particle", has the measured figures).
double bytesPerParticle(const compute::SimulationSettings& sim, int historySlots, int wallHistorySlots) {
  double bytes = 0, widest = 0;
  const compute::FieldInfo* table = compute::fieldTable(sim.precision == compute::Precision::kFloat);
  const double slotBytes = historySlots > 0 ? 1 : 0;  // each candidate's resolved slot (none without history)
  for (int k = 0; k < compute::kNumFields; ++k) {
    const auto& f = table[k];
    const double slots = f.multiplicity == compute::Multiplicity::kContactSlots ? historySlots
                         : f.multiplicity == compute::Multiplicity::kWallSlots  ? wallHistorySlots
                                                                                : 1;
    bytes += double(f.elementBytes) * slots;
    widest = std::max(widest, double(f.elementBytes));
  }
  const double cellSort = 4 + 4 + 12;                              // key, permutation, displacement since rebuild
  const double neighbours = 16 * (sizeof(pflow::Index) + slotBytes) + 4;  // candidates, slot bytes, count
  const double walls = 4 * sizeof(pflow::Index) + 4 + 4;          // wall candidates, count, plane mask
  return bytes + widest + cellSort + neighbours + walls;
}

}  // namespace

Result<SceneSummary> summarize(const LoadedScene& scene) {
  const compute::RunConfig& c = scene.config;
  if (c.solver == compute::Solver::kSph) return summarizeSph(scene);
  SceneSummary s;
  const auto& p = c.particles;
  s.particles = p.size();
  if (!p.radius.empty()) {
    s.minRadius = *std::min_element(p.radius.begin(), p.radius.end());
    s.maxRadius = *std::max_element(p.radius.begin(), p.radius.end());
  }
  for (double r : p.radius) s.solidVolume += 4.0 / 3.0 * std::numbers::pi * r * r * r;
  for (const auto& info : scene.sets)
    s.sets.push_back({info, info.regionVolume > 0 ? info.solidVolume / info.regionVolume : 0.0});
  s.planes = c.planes.size();
  s.meshes = c.meshes.size();
  for (const auto& m : c.meshes) s.triangles += m.triangles.size();
  s.surfaces = scene.surfaces;

  auto ts = compute::chooseTimeStep(c);
  if (!ts) return ts.status();
  s.rayleighTime = ts.value().rayleighTime;
  s.dt = ts.value().dt;
  s.dtReason = ts.value().reason;
  s.warnings = ts.value().warnings;
  s.steps = std::llround(c.sim.duration / s.dt);

  auto setup = compute::prepareEngineSetup(c);
  if (!setup) return setup.status();
  const auto& g = setup.value().grid;
  s.cells = {g.nx, g.ny, g.nz};
  s.cellSize = g.cellSize;
  s.skin = setup.value().skin;
  s.domain = {g.lo, g.lo + Vec3d{g.nx * g.cellSize, g.ny * g.cellSize, g.nz * g.cellSize}};
  if (c.sim.domain) s.domain = *c.sim.domain;
  const Vec3d e = s.domain.hi - s.domain.lo;
  const double volume = e.x * e.y * e.z;
  s.domainSolidFraction = volume > 0 ? s.solidVolume / volume : 0;

  s.model = compute::deriveModel(c);
  compute::SimulationSettings sim = c.sim;
  sim.precision = s.model.precision;
  s.bytesPerParticle = bytesPerParticle(sim, setup.value().historySlots, setup.value().wallHistorySlots);
  const double cellBytes = 4.0 * (double(g.nx) * g.ny * g.nz + 1);
  const double triangleBytes = double(s.triangles) * (3 * sizeof(Vec3d) * 2 + 4 * 4);  // vertices (rest + moved), ids
  s.memoryBytes = s.bytesPerParticle * double(s.particles) + cellBytes + triangleBytes;
  return s;
}

std::string toJson(const SceneSummary& s) {
    nlohmann::json sets = nlohmann::json::array(), surfaces = nlohmann::json::array();
    for (const auto& set : s.sets)
      sets.push_back({{"name", set.info.name}, {"method", set.info.method}, {"count", set.info.count},
                      {"radius_min_m", set.info.minRadius}, {"radius_max_m", set.info.maxRadius},
                      {"solid_volume_m3", set.info.solidVolume}, {"region_volume_m3", set.info.regionVolume},
                      {"solid_fraction", set.solidFraction}});
    for (const auto& f : s.surfaces)
      surfaces.push_back({{"id", f.id}, {"name", f.name}, {"wall", f.wall}, {"triangles", f.triangles}, {"area_m2", f.area}});
    nlohmann::json model = nlohmann::json::array(), proposals = nlohmann::json::array();
    for (const auto& d : s.model.decisions) model.push_back({{"name", d.name}, {"choice", d.choice}, {"reason", d.reason}});
    for (const auto& p : s.model.proposals)
      proposals.push_back({{"executor", p.executor}, {"precision", p.precision}, {"dt_fraction", p.dtFraction},
                           {"softening", p.softening}, {"skin_fraction", p.skinFraction},
                           {"rebuild_interval", p.rebuildInterval}, {"worst_error", p.worstError},
                           {"wall_s_per_sim_s", p.cost}, {"problems", p.problems}});
    const nlohmann::json j{{"solver", s.solver},
                          {"particles", s.particles},
                          {"radius_min_m", s.minRadius},
                          {"radius_max_m", s.maxRadius},
                          {"solid_volume_m3", s.solidVolume},
                          {"sets", sets},
                          {"planes", s.planes},
                          {"meshes", s.meshes},
                          {"triangles", s.triangles},
                          {"surfaces", surfaces},
                          {"domain_m", {{s.domain.lo.x, s.domain.lo.y, s.domain.lo.z}, {s.domain.hi.x, s.domain.hi.y, s.domain.hi.z}}},
                          {"solid_fraction_of_domain", s.domainSolidFraction},
                          {"cells", s.cells},
                          {"cell_size_m", s.cellSize},
                          {"skin_m", s.skin},
                          {"rayleigh_time_s", s.rayleighTime},
                          {"dt_s", s.dt},
                          {"dt_reason", s.dtReason},
                          {"warnings", s.warnings},
                          {"steps", s.steps},
                          {"bytes_per_particle", s.bytesPerParticle},
                          {"memory_estimate_bytes", s.memoryBytes},
                          {"model", model},
                          {"accuracy_proposals", proposals}};
  return j.dump();
}

}  // namespace pflow::frontend
