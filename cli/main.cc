// pflow: the command-line client. In-process commands (run, build, validate) and, in builds with the services,
// cluster commands (submit, jobs, job, nodes, cancel, watch, fetch) that talk to the manager and the back-end.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/RenderCommand.h"
#include "cli/RunCommand.h"
#ifdef PFLOW_HAVE_SERVICES
#include "cli/ClusterCommands.h"
#include "display/ViewerSources.h"
#endif
#include "common/Log.h"

int main(int argc, char** argv) {
  CLI::App app{"pflow: GPU particle-flow (DEM) simulation"};
  app.require_subcommand(1);
  std::string logLevel = "info";
  app.add_option("--log-level", logLevel, "trace, debug, info, warn, error")->capture_default_str();

  pflow::cli::RunOptions run;
  auto* runCmd = app.add_subcommand("run", "run a scene in this process and write snapshots (HDF5 + XDMF)");
  runCmd->add_option("scene", run.scenePath, "scene file (YAML; not with --resume)")->check(CLI::ExistingFile);
  runCmd->add_option("-o,--output", run.outputPath, "output HDF5 file (default: the scene's output.file, else SCENE.h5)");
  runCmd->add_option("--executor", run.executor,
                     "auto (the GPU where one is visible), cpu (OpenMP) or cuda (an error without a GPU)")
      ->capture_default_str();
  runCmd->add_option("--device", run.device, "CUDA device index")->capture_default_str();
  runCmd->add_option("--threads", run.threads, "CPU threads (default: all)");
  runCmd->add_option("--progress", run.progressSeconds, "seconds between progress lines (0: none)")->capture_default_str();
  runCmd->add_flag("--json", run.json, "print the summary as JSON on stdout");
  runCmd->add_option("--steps", run.maxSteps, "stop at this step, counted from the scene's start (default: the scene's duration)");
  runCmd->add_option("--checkpoint-every", run.checkpointEvery,
                     "write a checkpoint at the first neighbour rebuild after every N steps (DEM; docs/operations.md)");
  runCmd->add_option("--checkpoint-wall", run.checkpointWallSeconds,
                     "also a checkpoint at the first rebuild after this many wall-clock seconds since the last (0: never)")
      ->capture_default_str();
  runCmd->add_option("--checkpoint", run.checkpointPath, "checkpoint file (default: OUT.ckpt.h5; the one before is kept as PATH.1)");
  runCmd->add_option("--resume", run.resumePath, "go on from this checkpoint (or PATH.1 where PATH is unreadable); needs -o");

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

  pflow::cli::RenderArgs render, plot;
  auto* renderCmd = pflow::cli::addRenderCommand(app, render);
  auto* plotCmd = pflow::cli::addPlotCommand(app, plot);
  pflow::cli::JobSnapshotsFn jobSnapshots;

#ifdef PFLOW_HAVE_SERVICES
  pflow::cli::Endpoints endpoints;
  bool qjsonUsers = false;
  app.add_option("--manager", endpoints.manager, "manager host:port (else $PFLOW_MANAGER, the config file, 127.0.0.1:50051)");
  app.add_option("--backend", endpoints.backend, "back-end host:port (else $PFLOW_BACKEND, the config file, 127.0.0.1:50053)");
  app.add_option("--ca", endpoints.ca, "the pflow CA certificate that verifies the services (else $PFLOW_CA, `ca:` in the config file)");
  app.add_flag("--insecure", endpoints.insecure, "plaintext, for a stack started with --insecure (loopback only)");
  pflow::cli::UserOptions users;
  auto* adminCmd = app.add_subcommand("admin", "administration (admins only)")->require_subcommand(1);
  auto* userCmd = adminCmd->add_subcommand("user", "users and their tokens")->require_subcommand(1);
  auto* userAdd = userCmd->add_subcommand("add", "add a user and print its token (once)");
  userAdd->add_option("name", users.name, "user name: 1-64 of [A-Za-z0-9._-]")->required();
  userAdd->add_flag("--admin", users.admin, "the user is an admin (sees every job, manages users)");
  auto* userRotate = userCmd->add_subcommand("rotate", "give a user a new token (the old one stops working) and print it");
  userRotate->add_option("name", users.name, "user name")->required();
  auto* userRemove = userCmd->add_subcommand("remove", "remove a user (its jobs stay)");
  userRemove->add_option("name", users.name, "user name")->required();
  auto* userList = userCmd->add_subcommand("list", "list the users");
  for (auto* c : {userAdd, userRotate, userRemove, userList}) c->add_flag("--json", qjsonUsers, "print JSON");
  bool qjson = false, allJobs = false;
  std::string jobId;
  pflow::cli::SubmitOptions submit;
  auto* submitCmd = app.add_subcommand("submit", "submit a scene as a job to the manager");
  submitCmd->add_option("scene", submit.scenePath, "scene file (YAML)")->required()->check(CLI::ExistingFile);
  submitCmd->add_option("--name", submit.name, "job name (default: the scene's file name)");
  submitCmd->add_flag("--wait,!--no-wait", submit.wait, "queue when too few devices are free (default), or refuse");
  submitCmd->add_option("--max-devices", submit.maxDevices, "at most this many devices (0: as the particle count deserves)");
  submitCmd->add_flag("--watch", submit.watch, "then watch the job to its end");
  submitCmd->add_flag("--json", qjson, "print JSON");
  auto* jobsCmd = app.add_subcommand("jobs", "list jobs (active ones; --all for every job)");
  jobsCmd->add_flag("--all", allJobs, "include finished jobs");
  jobsCmd->add_flag("--json", qjson, "print JSON");
  auto* jobCmd = app.add_subcommand("job", "show one job");
  jobCmd->add_option("id", jobId, "job id")->required();
  jobCmd->add_flag("--json", qjson, "print JSON");
  auto* nodesCmd = app.add_subcommand("nodes", "list nodes and their devices (state, memory, load, job)");
  nodesCmd->add_flag("--json", qjson, "print JSON");
  auto* deleteCmd = app.add_subcommand("delete", "delete a finished job and its snapshots and checkpoints");
  deleteCmd->add_option("id", jobId, "job id")->required();
  deleteCmd->add_flag("--json", qjson, "print JSON");
  auto* cancelCmd = app.add_subcommand("cancel", "cancel a job");
  cancelCmd->add_option("id", jobId, "job id")->required();
  cancelCmd->add_flag("--json", qjson, "print JSON");
  auto* watchCmd = app.add_subcommand("watch", "follow a job's progress until it ends");
  watchCmd->add_option("id", jobId, "job id")->required();
  watchCmd->add_flag("--json", qjson, "print one JSON object per event");
  pflow::cli::FetchOptions fetch;
  bool fetchLast = false, noGrid = false, noProbes = false;
  std::int64_t fetchStep = -1;
  auto* fetchCmd = app.add_subcommand("fetch", "download a job's snapshot from the back-end into an HDF5 file (+ .xmf)");
  fetchCmd->add_option("id", fetch.jobId, "job id")->required();
  auto* stepOpt = fetchCmd->add_option("--step", fetchStep, "the snapshot at this step");
  fetchCmd->add_flag("--last", fetchLast, "the last snapshot (default)")->excludes(stepOpt);
  fetchCmd->add_option("-o,--output", fetch.output, "output HDF5 file")->required();
  fetchCmd->add_option("--fields", fetch.fields, "particle fields (default: all)");
  fetchCmd->add_flag("--no-grid", noGrid, "leave out the grid fields");
  fetchCmd->add_flag("--no-probes", noProbes, "leave out an SPH job's probe series (else /probes and OUTPUT.probes.csv)");
  fetchCmd->add_flag("--json", qjson, "print JSON");
#endif

  CLI11_PARSE(app, argc, argv);
  pflow::log::init("pflow", logLevel);
#ifdef PFLOW_HAVE_SERVICES
  const bool cluster = *submitCmd || *jobsCmd || *jobCmd || *nodesCmd || *cancelCmd || *deleteCmd || *watchCmd || *fetchCmd || *adminCmd;
  if (cluster) {
    if (pflow::Status s = endpoints.resolve(); !s) {
      std::fprintf(stderr, "pflow: %s\n", s.message().c_str());
      return pflow::cli::exitCodeFor(s);
    }
  }
  if (*adminCmd) {
    for (auto* c : {userAdd, userRotate, userRemove, userList})
      if (c->parsed()) users.action = c->get_name();
    return pflow::cli::manageUsers(endpoints, users, qjsonUsers);
  }
  if (*submitCmd) return pflow::cli::submitJob(endpoints, submit, qjson);
  if (*jobsCmd) return pflow::cli::listJobs(endpoints, allJobs, qjson);
  if (*jobCmd) return pflow::cli::showJob(endpoints, jobId, qjson);
  if (*nodesCmd) return pflow::cli::listNodes(endpoints, qjson);
  if (*cancelCmd) return pflow::cli::cancelJob(endpoints, jobId, qjson);
  if (*deleteCmd) return pflow::cli::deleteJob(endpoints, jobId, qjson);
  if (*watchCmd) return pflow::cli::watchJob(endpoints, jobId, qjson);
  if (*fetchCmd) {
    if (stepOpt->count() > 0) {
      if (fetchStep < 0) {
        std::fprintf(stderr, "pflow fetch: --step %lld: a step is >= 0 (leave --step out, or give --last, for the last snapshot)\n",
                     static_cast<long long>(fetchStep));
        return pflow::cli::kExitInvalid;
      }
      fetch.step = fetchStep;
    }
    fetch.grid = !noGrid;
    fetch.probes = !noProbes;
    return pflow::cli::fetchSnapshot(endpoints, fetch, qjson);
  }
  jobSnapshots = [&endpoints]() -> pflow::Result<pflow::cli::JobSnapshots> {
    if (pflow::Status s = endpoints.resolve(); !s) return s;
    return pflow::cli::JobSnapshots{pflow::display::makeGrpcSnapshotSource(endpoints.backend), endpoints.token};
  };
#endif
  if (*renderCmd) return pflow::cli::runRender(render, jobSnapshots);
  if (*plotCmd) return pflow::cli::runRender(plot, jobSnapshots);

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
