// pflow-janssen: Janssen's wall-stress saturation in a silo (bench/JanssenSilo.h; docs/accuracy.md, "Janssen"). One
// JSON line with the fit and the checks, and --csv the profile (depth, wall normal and shear stress).
//   pflow-janssen --executor cuda --csv docs/accuracy/janssen_cuda.csv
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <string>

#include "bench/JanssenSilo.h"
#include "common/Log.h"

int main(int argc, char** argv) {
  CLI::App app{"pflow-janssen: Janssen's wall-stress saturation in a silo"};
  pflow::bench::JanssenOptions o;
  std::string executor = "cpu", csv;
  app.add_option("--executor", executor, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.add_option("--precision", o.precision, "double or float")->check(CLI::IsMember({"double", "float"}))->capture_default_str();
  app.add_option("--radius", o.radius, "silo radius [m]")->capture_default_str();
  app.add_option("--fill-height", o.fillHeight, "height of the starting lattice [m]")->capture_default_str();
  app.add_option("--wall-friction", o.wallFriction, "bead-wall friction")->capture_default_str();
  app.add_option("--settle", o.settle, "[s]")->capture_default_str();
  app.add_option("--csv", csv, "the profile");
  CLI11_PARSE(app, argc, argv);
  pflow::log::init("pflow-janssen", "warn");
  const auto kind = executor == "cuda" ? pflow::compute::ExecutorKind::kCuda : pflow::compute::ExecutorKind::kCpu;
  const pflow::bench::JanssenResult r = pflow::bench::runJanssen(o, kind);
  nlohmann::json j{{"executor", executor},          {"precision", o.precision},       {"particles", r.particles},
                   {"wall_s", r.wall},              {"bulk_density", r.bulkDensity},  {"surface_m", r.surface},
                   {"weight_n", r.weight},          {"floor_load_n", r.floorLoad},    {"wall_shear_load_n", r.wallShearLoad},
                   {"mobilised_friction", r.mobilised}, {"sigma_inf_fit_pa", r.sigmaInf}, {"lambda_m", r.lambda},
                   {"janssen_sigma_inf_pa", r.janssenInf}, {"K", r.K},              {"fit_rms", r.fitResidual},
                   {"bands", r.bands.size()}};
  if (!r.error.empty()) j["error"] = r.error;
  std::printf("%s\n", j.dump().c_str());
  if (!csv.empty() && r.error.empty()) {
    std::ofstream f(csv);
    f << "depth_m,wall_normal_stress_pa,wall_shear_stress_pa,sigma_inf_fit_pa,lambda_m,janssen_sigma_inf_pa,K,bulk_density\n";
    for (const auto& b : r.bands)
      f << b.depth << "," << b.normal << "," << b.shear << "," << r.sigmaInf << "," << r.lambda << "," << r.janssenInf << "," << r.K << ","
        << r.bulkDensity << "\n";
  }
  return r.error.empty() ? 0 : 1;
}
