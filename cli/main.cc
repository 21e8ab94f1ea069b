// pflow: the command-line client. This build has the in-process commands (run, build, validate); the
// cluster commands (submit, jobs, nodes, cancel, watch, fetch) come with the services.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/RunCommand.h"
#include "common/Log.h"

int main(int argc, char** argv) {
  CLI::App app{"pflow: GPU particle-flow (DEM) simulation"};
  app.require_subcommand(1);
  std::string logLevel = "info";
  app.add_option("--log-level", logLevel, "trace, debug, info, warn, error")->capture_default_str();

  pflow::cli::RunOptions run;
  auto* runCmd = app.add_subcommand("run", "run a scene in this process and write snapshots (HDF5 + XDMF)");
  runCmd->add_option("scene", run.scenePath, "scene file (YAML)")->required()->check(CLI::ExistingFile);
  runCmd->add_option("-o,--output", run.outputPath, "output HDF5 file (default: the scene's output.file, else SCENE.h5)");
  runCmd->add_option("--executor", run.executor, "auto, cpu or cuda")->capture_default_str();
  runCmd->add_option("--threads", run.threads, "CPU threads (default: all)");
  runCmd->add_option("--progress", run.progressSeconds, "seconds between progress lines (0: none)")->capture_default_str();
  runCmd->add_flag("--json", run.json, "print the summary as JSON on stdout");
  runCmd->add_option("--steps", run.maxSteps, "stop after this many steps (default: the scene's duration)");

  pflow::cli::RunOptions build;
  build.initialOnly = true;
  auto* buildCmd = app.add_subcommand(
      "build", "generate the scene's particles and geometry and write the initial state (HDF5 + XDMF), without running");
  buildCmd->add_option("scene", build.scenePath, "scene file (YAML)")->required()->check(CLI::ExistingFile);
  buildCmd->add_option("-o,--output", build.outputPath, "output HDF5 file (default: the scene's output.file, else SCENE.h5)");
  buildCmd->add_flag("--json", build.json, "print the summary as JSON on stdout");

  std::string validatePath;
  bool validateJson = false;
  auto* valCmd = app.add_subcommand("validate", "check a scene file and summarise it");
  valCmd->add_option("scene", validatePath, "scene file (YAML)")->required()->check(CLI::ExistingFile);
  valCmd->add_flag("--json", validateJson, "print the result as JSON");

  CLI11_PARSE(app, argc, argv);
  pflow::log::init("pflow", logLevel);

  if (*valCmd) return pflow::cli::validateScene(validatePath, validateJson);

  const bool building = buildCmd->parsed();
  if (building) run = build;
  auto result = pflow::cli::runScene(run);
  if (!result) {
    std::fprintf(stderr, "pflow %s: %s\n", building ? "build" : "run", result.status().message().c_str());
    return pflow::cli::exitCodeFor(result.status());
  }
  if (run.json) {
    const auto& s = result.value();
    nlohmann::json j{{"output", s.outputPath}, {"xdmf", s.xdmfPath}, {"steps", s.steps},
                     {"simulated_time_s", s.simulatedTime}, {"wall_s", s.wallSeconds},
                     {"particle_steps_per_s", s.particleStepsPerSecond}, {"particles", s.particles},
                     {"snapshots", s.snapshots}, {"executor", s.executor}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}
