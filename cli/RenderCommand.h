// `pflow render FILE.h5|JOB`: one snapshot as a PNG (display/Renderer.h: the web viewer's code in headless Chromium).
#pragma once
#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"
#include "display/Renderer.h"

namespace pflow::cli {

struct RenderArgs {
  std::string target;          // a snapshot file, else a job id
  std::int64_t step = -1;      // -1 = the last
  bool last = false;
  std::string size = "1600x1000";
  std::vector<double> range;   // min max
  bool json = false;
  bool noParticles = false, withParticles = false;
  display::RenderOptions options;
};

CLI::App* addRenderCommand(CLI::App& app, RenderArgs& args);
// `pflow plot FILE.h5|JOB`: the run's time series as charts (the same machinery, options.plot).
CLI::App* addPlotCommand(CLI::App& app, RenderArgs& args);

// A job's snapshots and the token to read them with (the back-end's, over gRPC); absent in builds without services.
struct JobSnapshots {
  std::unique_ptr<display::SnapshotSource> source;
  std::string token;
};
using JobSnapshotsFn = std::function<Result<JobSnapshots>()>;

int runRender(RenderArgs& args, const JobSnapshotsFn& jobSnapshots);

}  // namespace pflow::cli
