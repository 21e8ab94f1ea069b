// pflow-generate-bench: time of the particle generators on monodisperse spheres in a cubic box.
// Prints one JSON line per run: method, particles generated, solid fraction requested and reached, seconds.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <iostream>
#include <numbers>
#include <string>
#include <vector>

#include "frontend/generators/Generators.h"

int main(int argc, char** argv) {
  using namespace pflow;
  using namespace pflow::frontend;
  CLI::App app{"pflow-generate-bench: random sequential addition and tiled fill of a box"};
  long n = 1000000;
  double fraction = 0.30, radius = 0.001;
  std::uint64_t seed = 1;
  int repeats = 1;
  std::vector<std::string> methods{"random", "tiled"};
  app.add_option("-n,--particles", n, "particles (sets the box edge with the solid fraction)")->capture_default_str();
  app.add_option("--solid-fraction", fraction, "solid fraction of the box")->capture_default_str();
  app.add_option("--radius", radius, "particle radius [m]")->capture_default_str();
  app.add_option("--seed", seed, "random seed")->capture_default_str();
  app.add_option("--repeats", repeats, "runs per method")->capture_default_str();
  app.add_option("--methods", methods, "random, tiled")->delimiter(',');
  CLI11_PARSE(app, argc, argv);

  const double volume = static_cast<double>(n) * 4.0 / 3.0 * std::numbers::pi * radius * radius * radius / fraction;
  const double edge = std::cbrt(volume);
  const auto region = Region::box({0, 0, 0}, {edge, edge, edge});
  if (!region) {
    std::cerr << region.status().toString() << "\n";
    return 1;
  }
  const auto size = SizeDistribution::single(radius);
  int rc = 0;
  for (int rep = 0; rep < repeats; ++rep) {
    for (const std::string& method : methods) {
      const auto t0 = std::chrono::steady_clock::now();
      Result<Particles> result = Status(StatusCode::kInvalidArgument, "unknown method '" + method + "'");
      if (method == "random") {
        RandomOptions options;
        options.count = static_cast<std::size_t>(n);
        result = generateRandom(region.value(), size, options, seed + rep);
      } else if (method == "tiled") {
        TiledOptions options;
        options.solidFraction = fraction;
        result = generateTiled(region.value(), size, options, seed + rep);
      }
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      nlohmann::json line{{"method", method}, {"requested_n", n}, {"requested_solid_fraction", fraction}, {"box_edge", edge}, {"seconds", seconds}};
      if (result) {
        double solid = 0;
        for (double r : result->radius) solid += 4.0 / 3.0 * std::numbers::pi * r * r * r;
        line["n"] = result->size();
        line["solid_fraction"] = solid / volume;
      } else {
        line["error"] = result.status().message();
        rc = 1;
      }
      std::cout << line.dump() << std::endl;
    }
  }
  return rc;
}
