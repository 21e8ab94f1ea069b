#include "cli/RenderCommand.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <regex>

#include "cli/RunCommand.h"
#include "display/FileSnapshotSource.h"

namespace pflow::cli {

CLI::App* addRenderCommand(CLI::App& app, RenderArgs& a) {
  auto& o = a.options;
  auto* cmd = app.add_subcommand("render", "draw a snapshot as a PNG (particles, walls, a grid-field slice, streamlines) with headless Chromium");
  cmd->add_option("target", a.target, "a snapshot file (.h5, from pflow run or pflow fetch) or a job id")->required();
  auto* stepOpt = cmd->add_option("--step", a.step, "the snapshot at this step");
  cmd->add_flag("--last", a.last, "the last snapshot (default)")->excludes(stepOpt);
  cmd->add_option("-o,--output", o.output, "PNG file")->capture_default_str();
  cmd->add_option("--color-by", o.colorBy, "speed, height, diameter, a stored particle field (pressure, material, ...) or |vector|");
  cmd->add_option("--colormap", o.colormap, "viridis, grey, coolwarm, inferno, categories (default: viridis; categories for material, kind)");
  cmd->add_option("--range", a.range, "MIN MAX of the colour bar (default: the snapshot's)")->expected(2);
  cmd->add_option("--view", o.view, "iso, top, front (along +y) or side (along -x); default iso, or along the slice's axis");
  cmd->add_option("--clip", o.clip, "AXIS=VALUE: cut away what lies beyond VALUE (m) along AXIS");
  cmd->add_option("--slice", o.slice, "AXIS=VALUE: draw a grid field on this slice (from the file, else computed as the back-end does)");
  cmd->add_option("--field", o.field, "the slice's grid field: solid_fraction (default; fluid_fraction for SPH), mean_velocity, "
                                       "granular_temperature, mean_pressure");
  cmd->add_flag("--streamlines", o.streamlines, "streamlines of the in-plane mean velocity on the slice");
  cmd->add_flag("--particles", a.withParticles, "draw the particles with a slice too");
  cmd->add_flag("--no-particles", a.noParticles, "leave the particles out");
  cmd->add_option("--size", a.size, "WIDTHxHEIGHT in pixels")->capture_default_str();
  cmd->add_option("--title", o.title, "the picture's title (default: the job id or file name)");
  cmd->add_option("--timeout", o.timeoutSeconds, "seconds to wait for the picture")->capture_default_str();
  cmd->add_flag("--json", a.json, "print what was drawn as JSON");
  return cmd;
}

CLI::App* addPlotCommand(CLI::App& app, RenderArgs& a) {
  auto& o = a.options;
  o.plot = true;
  o.output = "pflow-series.png";
  auto* cmd = app.add_subcommand("plot", "draw a run's time series as charts (DEM: kinetic energy, contacts, mass flow through planes; "
                                         "SPH: probes and gauges)");
  cmd->add_option("target", a.target, "a snapshot file (.h5, from pflow run or pflow fetch) or a job id")->required();
  cmd->add_option("-o,--output", o.output, "PNG file")->capture_default_str();
  cmd->add_option("--series", o.series, "the series to draw (names or prefixes: kinetic_energy, contacts, mass_past, P, ...); default all");
  cmd->add_option("--size", a.size, "WIDTHxHEIGHT in pixels")->capture_default_str();
  cmd->add_option("--title", o.title, "the picture's title (default: the job id or file name)");
  cmd->add_option("--timeout", o.timeoutSeconds, "seconds to wait for the picture")->capture_default_str();
  cmd->add_flag("--json", a.json, "print what was drawn as JSON");
  return cmd;
}

int runRender(RenderArgs& a, const JobSnapshotsFn& jobSnapshots) {
  auto& o = a.options;
  const std::string cmd = o.plot ? "pflow plot" : "pflow render";
  std::smatch m;
  static const std::regex size(R"(^([0-9]{1,5})x([0-9]{1,5})$)");
  if (!std::regex_match(a.size, m, size)) {
    std::fprintf(stderr, "%s: --size '%s': WIDTHxHEIGHT in pixels, e.g. 1600x1000\n", cmd.c_str(), a.size.c_str());
    return kExitInvalid;
  }
  o.width = std::stoi(m[1]), o.height = std::stoi(m[2]);
  if (a.range.size() == 2) o.min = a.range[0], o.max = a.range[1];
  if (a.withParticles && a.noParticles) {
    std::fprintf(stderr, "pflow render: --particles and --no-particles together\n");
    return kExitInvalid;
  }
  if (a.withParticles || a.noParticles) o.particlesSet = true, o.particles = a.withParticles;
  if (Status st = display::validateRenderOptions(o); !st) {
    std::fprintf(stderr, "%s\n", st.message().c_str());
    return kExitInvalid;
  }
  display::SnapshotRequest request;
  if (a.step >= 0) request.step = a.step;
  std::unique_ptr<display::SnapshotSource> source;
  std::string token;
  std::error_code ec;
  if (std::filesystem::is_regular_file(a.target, ec)) {
    source = display::makeFileSnapshotSource(a.target);
    if (o.title.empty()) o.title = std::filesystem::path(a.target).filename().string();
  } else if (a.target.ends_with(".h5") || a.target.find('/') != std::string::npos) {
    std::fprintf(stderr, "%s: %s: no such file\n", cmd.c_str(), a.target.c_str());
    return kExitIo;
  } else {
    if (!jobSnapshots) {
      std::fprintf(stderr, "%s: %s is not a file, and this pflow was built without the services to fetch a job\n", cmd.c_str(), a.target.c_str());
      return kExitInvalid;
    }
    auto job = jobSnapshots();
    if (!job) {
      std::fprintf(stderr, "%s: %s\n", cmd.c_str(), job.status().message().c_str());
      return exitCodeFor(job.status());
    }
    source = std::move(job.value().source);
    token = job.value().token;
    request.job = a.target;
    if (o.title.empty()) o.title = "job " + a.target;
  }
  auto report = display::renderSnapshot(o, *source, token, request);
  if (!report) {
    const std::string& m = report.status().message();
    std::fprintf(stderr, "%s%s\n", m.rfind("pflow ", 0) == 0 ? "" : (cmd + ": ").c_str(), m.c_str());
    return exitCodeFor(report.status());
  }
  const auto& r = report.value();
  if (a.json) {
    nlohmann::json j{{"output", o.output}, {"width", o.width}, {"height", o.height}, {"step", r.step}, {"time_s", r.time},
                     {"particles", r.particles}, {"wall_s", r.seconds}, {"page", r.pageTiming}};
    std::printf("%s\n", j.dump().c_str());
  } else {
    if (o.plot) std::printf("%s: %dx%d, time series up to t = %g s, %.1f s\n", o.output.c_str(), o.width, o.height, r.time, r.seconds);
    else
      std::printf("%s: %dx%d, step %lld (t = %g s), %llu particles, %.1f s\n", o.output.c_str(), o.width, o.height, (long long)r.step, r.time,
                  (unsigned long long)r.particles, r.seconds);
  }
  return kExitOk;
}

}  // namespace pflow::cli
