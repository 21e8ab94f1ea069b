// pflow-beverloo: Beverloo's law from a flat-bottomed silo (docs/accuracy.md, "Beverloo"). For each orifice diameter
// D, ~3.4e4 polydisperse beads (radius 0.9-1.1 mm, uniform) on a lattice settle in a cylindrical silo (radius 40 mm)
// whose floor (a hopper cone 1 mm high: 1.6 degrees) has a circular orifice closed by a gate; the gate slides away
// and the mass past the orifice's plane is fitted by a line over a window of steady discharge: the flow rate W.
// W^{2/5} is linear in D (W = C rho_b sqrt(g) (D - k d)^{5/2}): its least-squares line gives C and k, with rho_b the
// settled bed's bulk density (measured in the bed's core) and d the mean diameter. One JSON line per orifice and one
// for the fit on stdout; --csv writes the rows.
//   pflow-beverloo --executor cuda --orifices 0.012,0.014,0.016,0.02
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "bench/BeverlooSilo.h"
#include "common/Log.h"

int main(int argc, char** argv) {
  CLI::App app{"pflow-beverloo: Beverloo's law from a flat-bottomed silo"};
  pflow::bench::BeverlooOptions o;
  std::string executor = "cpu";
  std::vector<double> orifices{0.012, 0.014, 0.016, 0.02};
  std::string csv;
  app.add_option("--orifices", orifices, "orifice diameters [m]")->delimiter(',');
  app.add_option("--executor", executor, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.add_option("--precision", o.precision, "double or float")->check(CLI::IsMember({"double", "float"}))->capture_default_str();
  app.add_option("--silo-radius", o.siloRadius, "[m]")->capture_default_str();
  app.add_option("--fill-height", o.fillHeight, "height of the lattice the beads start on [m]")->capture_default_str();
  app.add_option("--window", o.window, "steady discharge fitted [s]")->capture_default_str();
  app.add_option("--settle", o.settle, "settling before the gate opens [s]")->capture_default_str();
  app.add_option("--transient", o.transient, "discharge before the window [s]")->capture_default_str();
  app.add_option("--friction", o.friction, "bead-bead and bead-wall sliding friction")->capture_default_str();
  app.add_option("--csv", csv, "write the rows and the fit here");
  CLI11_PARSE(app, argc, argv);
  pflow::log::init("pflow-beverloo", "warn");
  const auto kind = executor == "cuda" ? pflow::compute::ExecutorKind::kCuda : pflow::compute::ExecutorKind::kCpu;
  std::vector<pflow::bench::BeverlooRow> rows;
  for (double D : orifices) {
    pflow::bench::BeverlooRow r = pflow::bench::runBeverloo(o, D, kind);
    nlohmann::json j{{"orifice_m", r.D}, {"flow_rate_kg_per_s", r.W}, {"bulk_density", r.bulkDensity}, {"mean_diameter", r.meanDiameter},
                     {"particles", r.particles}, {"wall_s", r.wall}, {"executor", executor}, {"precision", o.precision}};
    if (!r.error.empty()) j["error"] = r.error;
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
    if (r.error.empty()) rows.push_back(r);
  }
  if (rows.size() < 2) return 1;
  const pflow::bench::BeverlooFit f = pflow::bench::fitBeverloo(rows);
  const double C = f.C, k = f.k, rho = f.bulkDensity, d = f.meanDiameter, worst = f.worstResidual;
  nlohmann::json fit{{"fit", "beverloo"}, {"C", C}, {"k", k}, {"bulk_density", rho}, {"mean_diameter", d}, {"orifices", rows.size()},
                     {"worst_relative_residual", worst}};
  std::printf("%s\n", fit.dump().c_str());
  if (!csv.empty()) {
    std::ofstream f(csv);
    f << "orifice_m,flow_rate_kg_per_s,bulk_density_kg_per_m3,mean_diameter_m,particles,executor,precision,C_fit,k_fit\n";
    for (const pflow::bench::BeverlooRow& r : rows)
      f << r.D << "," << r.W << "," << r.bulkDensity << "," << r.meanDiameter << "," << r.particles << "," << executor << ","
        << o.precision << "," << C << "," << k << "\n";
  }
  return 0;
}
