// pflow-repose: the angle of repose of a heap of 1 mm glass beads (docs/accuracy.md, "Angle of repose"). Beads settle
// in a cylinder on a plate and the cylinder is lifted (--method lift), or they pour from a funnel (--method pour); the
// heap is measured: the highest bead top in rings about the
// axis, a line fitted between 25 % and 75 % of the heap's radius, over all azimuths and in four quadrants. One run per
// rolling-resistance coefficient given (the reference: Sunday et al. 2020, measured 25.2 +- 0.8 degrees, their DEM
// 25.3 at mu_r = 0.09); a JSON line each on stdout; --csv writes the rows, --profiles the heaps' surfaces.
//   pflow-repose --executor cuda --rolling 0,0.05,0.09,0.15
// A run longer than one sitting: --checkpoint FILE --wall-limit S stops it after S s (exit 3) and the same command
// goes on from FILE.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "bench/ReposeHeap.h"
#include "common/Log.h"

int main(int argc, char** argv) {
  CLI::App app{"pflow-repose: the angle of repose of a heap of glass beads"};
  pflow::bench::ReposeOptions o;
  std::string executor = "cpu", csv, profiles;
  std::vector<double> rolling{o.rolling};
  app.add_option("--rolling", rolling, "bead-bead (and, without --wall-rolling, bead-plate) rolling-resistance coefficients, one run each")
      ->delimiter(',');
  double wallRolling = -1;
  app.add_option("--wall-rolling", wallRolling,
                 "bead-plate (and funnel, cylinder) rolling resistance, if not the bead-bead one. pflow's torque is mu_r |Fn| R*: "
                 "R/2 between equal beads, R against a wall; Chrono's (Schwartz's) is mu_r |Fn| R for both, so Chrono's "
                 "mu_r = 0.09 is --rolling 0.18 --wall-rolling 0.09 here");
  app.add_option("--executor", executor, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.add_option("--precision", o.precision, "double or float")->check(CLI::IsMember({"double", "float"}))->capture_default_str();
  app.add_option("--particles", o.particles, "beads")->capture_default_str();
  app.add_option("--friction", o.friction, "bead-bead sliding friction")->capture_default_str();
  app.add_option("--method", o.method, "lift (a cylinder lifted off the beads) or pour (a funnel discharging onto the plate)")
      ->check(CLI::IsMember({"lift", "pour"}))->capture_default_str();
  app.add_option("--orifice", o.orifice, "pour: the funnel's orifice diameter [m]")->capture_default_str();
  app.add_option("--pour-height", o.pourHeight, "pour: the orifice above the plate [m]")->capture_default_str();
  app.add_option("--pour", o.pour, "pour: seconds from the gate's opening to the end of the pouring")->capture_default_str();
  app.add_option("--roughness", o.roughness, "the plate's bumps [m] (0: flat)")->capture_default_str();
  app.add_option("--floor", o.floor, "the plate's roughness: field (bumps up to --roughness) or beads (a layer of glued beads)")
      ->check(CLI::IsMember({"field", "beads"}))->capture_default_str();
  app.add_option("--plate", o.plateHalfWidth, "the plate's half-width [m] (0: 4 cylinder radii poured, 6 lifted)")->capture_default_str();
  app.add_option("--settle", o.settle, "in the cylinder before the lift [s]")->capture_default_str();
  app.add_option("--lift-speed", o.liftSpeed, "[m/s]")->capture_default_str();
  app.add_option("--rest", o.rest, "after the lift [s]")->capture_default_str();
  app.add_option("--checkpoint", o.checkpoint,
                 "go on from this checkpoint file if it exists; with --wall-limit, write it there when the limit stops the run");
  app.add_option("--wall-limit", o.wallLimit,
                 "stop after this many seconds of stepping (at the next neighbour rebuild), writing --checkpoint; exit 3")
      ->capture_default_str();
  app.add_option("--csv", csv, "write the rows here");
  app.add_option("--profiles", profiles, "write the heaps' surfaces here (rolling, wall_rolling, radius, height, and the run's floor, "
                                         "pour height, precision and --plate, which tell runs apart)");
  CLI11_PARSE(app, argc, argv);
  pflow::log::init("pflow-repose", "warn");
  if (!o.checkpoint.empty() && rolling.size() != 1) {
    std::fprintf(stderr, "pflow-repose: --checkpoint holds one run: give one --rolling value\n");
    return 2;
  }
  if (o.wallLimit > 0 && o.checkpoint.empty()) {
    std::fprintf(stderr, "pflow-repose: --wall-limit needs --checkpoint (where the unfinished run is kept)\n");
    return 2;
  }
  const auto kind = executor == "cuda" ? pflow::compute::ExecutorKind::kCuda : pflow::compute::ExecutorKind::kCpu;
  o.onProgress = [](double t, std::int64_t steps, double wall) {
    std::fprintf(stderr, "t = %.2f s, %lld steps, %.1f s\n", t, (long long)steps, wall);
  };
  std::ofstream rows, surf;
  if (!csv.empty()) {
    rows.open(csv);
    rows << "rolling,wall_rolling,friction,angle_deg,q0_deg,q1_deg,q2_deg,q3_deg,spread_deg,heap_radius_m,heap_height_m,fit_from_m,fit_to_m,"
            "kinetic_energy_J,particles,executor,precision,wall_s,floor,pour_height_m,plate_half_width_m\n";
  }
  if (!profiles.empty()) {
    surf.open(profiles);
    surf << "rolling,wall_rolling,radius_m,height_m,floor,pour_height_m,precision,plate_half_width_m\n";
  }
  int failed = 0, unfinished = 0;
  for (double mr : rolling) {
    o.rolling = mr, o.wallRolling = wallRolling >= 0 ? wallRolling : mr;
    const pflow::bench::ReposeResult r = pflow::bench::runRepose(o, kind);
    nlohmann::json j{{"rolling", mr}, {"wall_rolling", o.wallRolling}, {"friction", o.friction}, {"on_plate", r.onPlate}, {"lowest_m", r.lowest}, {"angle_deg", r.angle}, {"quadrants_deg", r.quadrant},
                     {"spread_deg", r.spread}, {"heap_radius_m", r.heapRadius}, {"heap_height_m", r.heapHeight},
                     {"kinetic_energy_J", r.kineticEnergy}, {"particles", r.particles}, {"wall_s", r.wall},
                     {"executor", executor}, {"precision", o.precision}, {"method", o.method},
                     {"floor", o.floor}, {"floor_beads", r.floorBeads}, {"pour_height_m", o.pourHeight}, {"plate_half_width_m", r.plateHalfWidth}};
    if (!r.error.empty()) j["error"] = r.error, ++failed;
    if (r.unfinished) {  // the heap is not measured: the run goes on from the checkpoint
      std::printf("%s\n", nlohmann::json{{"unfinished", true}, {"time_s", r.time}, {"wall_s", r.wall}, {"steps", r.steps}, {"rebuilds", r.rebuilds}, {"phases", r.phases}, {"triangles", r.triangles}, {"cell_m", r.cellSize}, {"contact_slots", r.contactSlots}, {"wall_slots", r.wallSlots}, {"checkpoint", o.checkpoint}}.dump().c_str());
      ++unfinished;
      continue;
    }
    j["time_s"] = r.time, j["steps"] = r.steps, j["rebuilds"] = r.rebuilds, j["phases"] = r.phases;
    j["triangles"] = r.triangles, j["cell_m"] = r.cellSize, j["contact_slots"] = r.contactSlots, j["wall_slots"] = r.wallSlots;
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
    if (rows.is_open() && r.error.empty())
      rows << mr << "," << o.wallRolling << "," << o.friction << "," << r.angle << "," << r.quadrant[0] << "," << r.quadrant[1] << "," << r.quadrant[2]
           << "," << r.quadrant[3] << "," << r.spread << "," << r.heapRadius << "," << r.heapHeight << "," << r.fitFrom << ","
           << r.fitTo << "," << r.kineticEnergy << "," << r.particles << "," << executor << "," << o.precision << "," << r.wall << "," << o.floor
           << "," << o.pourHeight << "," << r.plateHalfWidth << "\n";
    if (surf.is_open())
      for (std::size_t k = 0; k < r.profile.height.size(); ++k)
        if (r.profile.height[k] == r.profile.height[k]) surf << mr << "," << o.wallRolling << "," << r.profile.radius[k] << "," << r.profile.height[k] << "," << o.floor << "," << o.pourHeight << ","
                                                    << o.precision << "," << r.plateHalfWidth << "\n";
  }
  return failed ? 1 : unfinished ? 3 : 0;
}
