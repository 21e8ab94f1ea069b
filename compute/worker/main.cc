// pflow-worker: the MPI compute program the node agent starts for a job.
//
// Every rank loads the built model and runs the step loop on its own device over its share of the particles
// (compute/mpi's MpiDomain: decomposition, migration, ghosts, rebalancing). Rank 0 reports progress to the
// manager from a thread of its own (whose answer carries a cancel request) and sends the snapshots, gathered
// from all ranks in id order, to the back-end. A cancel request, or SIGTERM from the agent (forwarded by
// mpirun), stops the run at the next step boundary on every rank (one reduction per step), with the sink
// closed. Every outcome that one rank sees alone (a device that fails, a back-end that refuses a snapshot) is
// agreed on by all ranks before the next collective, so no rank is left waiting.
//
// Exit codes: 0 finished (or cancelled by the manager: it knows it asked), 1 bad options or model, 2 I/O (back-end or
// files), 3 the simulation failed (the message names particle, step and quantity), 143 stopped by SIGTERM/SIGINT that
// the manager did not ask for (an agent shutting down, preemption): the job is requeued. The last line on stderr is the
// reason the agent reports.
#include <mpi.h>

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <thread>

#include "common/Log.h"
#include "common/rpc/Rpc.h"
#include "compute/mpi/MpiDomain.h"
#include "backend/store/DemSeries.h"
#include "compute/dem/Simulation.h"
#include "compute/worker/JobCheckpoints.h"
#include "compute/worker/SnapshotSinks.h"
#include "compute/worker/WorkerOptions.h"
#include "compute/worker/WorkerRun.h"
#include "frontend/SceneLoader.h"
#include "pflow/manager/v1/node_registry.grpc.pb.h"

namespace {

using namespace pflow;
using worker::fail;
using worker::ProgressReporter;

void onStopSignal(int) { worker::g_stopSignal = 1; }

const char* environment(const char* name) { return std::getenv(name); }

// --devices slurm:KIND: each rank's device from srun's environment, shared with every rank (collective).
Result<std::vector<worker::LeasedDevice>> slurmDevices(const std::string& kind, int rank, int size) {
  auto mine = worker::slurmDevice(kind, environment);
  constexpr int kName = 256;
  std::vector<char> names(std::size_t(kName) * std::size_t(size), '\0');
  std::vector<int> indices(std::size_t(size), -1);
  char own[kName] = {};
  int index = -1;
  if (mine) {
    std::snprintf(own, sizeof own, "%s", mine.value().node.c_str());
    index = mine.value().index;
  }
  MPI_Allgather(own, kName, MPI_CHAR, names.data(), kName, MPI_CHAR, MPI_COMM_WORLD);
  MPI_Allgather(&index, 1, MPI_INT, indices.data(), 1, MPI_INT, MPI_COMM_WORLD);
  if (!mine) return mine.status();
  std::vector<worker::LeasedDevice> all;
  for (int r = 0; r < size; ++r) {
    if (indices[std::size_t(r)] < 0) return invalidArgument("--devices slurm:" + kind + ": rank " + std::to_string(r) + " found no device");
    all.push_back({std::string(&names[std::size_t(r) * kName]), kind, indices[std::size_t(r)]});
  }
  (void)rank;
  return all;
}

// `particles`: over all ranks.
manager::v1::Progress progressOf(const compute::Simulation& sim, std::int64_t totalSteps, double duration, double rate,
                                 double particles) {
  manager::v1::Progress p;
  p.set_step(sim.stepCount());
  p.set_total_steps(totalSteps);
  p.set_time(sim.time());
  p.set_duration(duration);
  p.set_particle_steps_per_second(rate);
  p.set_eta_seconds(rate > 0 ? double(totalSteps - sim.stepCount()) * particles / rate : 0);
  return p;
}

// Runs the job on this rank; returns the exit code (the same on every rank), or -1 - code when it stopped early (code 0:
// the manager cancelled it; 143: a signal from elsewhere, worker::stoppedExitCode).
int runRank(const worker::WorkerOptions& o, int rank, int ranks) {
  const bool lead = rank == 0;
  // The model as the frontend checked it: its files inside the model's folder only, as when it was built.
  frontend::LoadOptions confined;
  confined.confineFiles = true;
  auto scene = frontend::loadScene((std::filesystem::path(o.modelDir) / "scene.yaml").string(), confined);
  if (!scene) return fail(1, "cannot load the model: " + scene.status().message());
  if (scene.value().config.solver == compute::Solver::kSph) return worker::runSphRank(o, rank, ranks, scene.value());
  compute::RunConfig cfg = scene.value().config;
  if (o.threads > 0) cfg.sim.threads = o.threads;
  const worker::LeasedDevice& device = o.devices[std::size_t(rank)];
  const worker::RankPlacement place = worker::placeRank(o, rank, ranks, cfg);
  compute::SimulationOptions so;
  so.executor = place.executor;
  so.device = place.device;
  const auto& domain = place.domain;
  so.domain = domain;
  compute::Domain single;
  compute::Domain& all = domain ? static_cast<compute::Domain&>(*domain) : single;
  auto created = compute::Simulation::create(cfg, so);
  if (!created) return fail(created.status().code() == StatusCode::kInvalidArgument ? 1 : 3, created.status().message());
  compute::Simulation& sim = *created.value();
  const double particles = all.sum(double(sim.numParticles()));
  const std::string executorNote = sim.executorDescription() + ", " + sim.engine().precisionName() + " (device " +
                                   device.node + ":" + device.kind + ":" + std::to_string(device.index) + "; " +
                                   std::to_string(ranks) + " rank(s)" +
                                   (domain ? std::string(", ") + domain->strategyName() + " decomposition" : "") + ")";
  spdlog::info("job {}: rank {} of {}: {} of {} particles, executor {}", o.jobId, rank, ranks, sim.numParticles(),
               particles, executorNote);
  worker::JobCheckpoints checkpoints(o, "dem", sim.engine().precisionName(), scene.value().checkpointInterval, lead, all);
  auto resumed = checkpoints.resume(sim);
  if (!resumed) return fail(3, "resuming from the job's checkpoint: " + resumed.status().message());
  const std::int64_t firstStep = sim.stepCount();

  // The sink lives on rank 0; its failures are agreed on (the other ranks would wait in the next collective).
  std::unique_ptr<worker::SnapshotSink> sink;
  Status opened;
  if (lead) {
    auto made = o.backendAddress.empty() ? worker::makeFileSink(o.output) : worker::makeBackendSink(o);
    if (made) sink = std::move(made).value();
    else opened = made.status();
    if (opened.isOk()) opened = sink->writeGeometry(sim.geometry());
  }
  if (Status s = all.agree(opened); !s.isOk()) return fail(2, s.message());
  checkpoints.setOutputsDelivered([&] { return !sink || sink->delivered(); });
  const auto& fields = scene.value().outputFields;
  auto write = [&]() -> Status {  // collective: every rank's particles gathered on rank 0
    auto t = sim.timers().time(compute::Phase::kOutput);
    compute::ParticleSnapshot snap = sim.snapshot(fields);
    return all.agree(lead ? sink->write(snap) : Status::ok());
  };
  if (!resumed.value())  // a resumed run's snapshot of this step is on the back-end already
    if (Status s = write(); !s.isOk()) return fail(2, s.message());
  // The run's series (backend/store/DemSeries.h), sent to the back-end's /probes with each snapshot. A resumed run
  // samples again from its checkpoint's time; the back-end drops samples at or before the last it stored
  // (appendProbeSeries), so the job's series keeps one sample per time across attempts.
  backend::DemSeriesRecorder series(sim, all, cfg.series, cfg.surfaceNames);
  std::size_t seriesSent = 0;
  auto sendSeries = [&]() -> Status {
    seriesSent = std::min(seriesSent, series.series().time.size());  // after a reduce_dt rewind
    if (!lead || seriesSent == series.series().time.size()) return Status::ok();
    Status s = sink->writeProbes(backend::probeSamples(series.series(), seriesSent));
    if (s.isOk()) seriesSent = series.series().time.size();
    return s;
  };

  const double duration = cfg.sim.duration, interval = cfg.sim.snapshotInterval;
  const auto totalSteps = std::int64_t(std::llround(duration / sim.dt()));
  sim.scheduleOutput(interval, double(totalSteps) * sim.dt());  // snapshot times kept if reduce_dt halves dt
  ProgressReporter progress(lead ? o.managerAddress : std::string(), o.jobId, o.progressInterval, o.attempt);
  const auto start = std::chrono::steady_clock::now();
  auto lastPost = start - std::chrono::hours(1);
  bool cancelled = false;
  int stopWhy = 0;
  auto rate = [&](const compute::Simulation& s, double wall) { return wall > 0 ? particles * double(s.stepCount() - firstStep) / wall : 0; };
  auto observer = [&](const compute::Simulation& s) -> Status {
    series.sample(s, all);  // collective
    if (s.outputDue()) {
      if (Status st = write(); !st.isOk()) return st;
      if (Status st = all.agree(sendSeries()); !st.isOk()) return st;
    }
    checkpoints.maybeTake(s, sim.timers());
    if ((stopWhy = worker::stopAgreed(progress.cancelRequested(), domain)) != 0) {
      cancelled = true;
      return Status(StatusCode::kCancelled, "cancelled at step " + std::to_string(s.stepCount()));
    }
    const auto now = std::chrono::steady_clock::now();
    if (lead && std::chrono::duration<double>(now - lastPost).count() >= o.progressInterval) {
      lastPost = now;
      progress.post(progressOf(s, totalSteps, duration, rate(s, std::chrono::duration<double>(now - start).count()), particles),
                    executorNote);
    }
    return Status::ok();
  };
  Status run = sim.runUntil(duration, observer);
  if (run.isOk()) run = sim.finishRun();  // collective: no job that gained energy ends as a success
  if (cancelled) {
    spdlog::info("job {} cancelled at step {} (t = {} s)", o.jobId, sim.stepCount(), sim.time());
    if (sink)
      if (Status s = sink->close(); !s.isOk()) spdlog::warn("{}", s.message());
    return -1 - worker::stoppedExitCode(stopWhy);  // tells main: stopped (-1: by the manager, its cancel)
  }
  if (Status s = all.agree(sendSeries()); !s.isOk() && run.isOk()) run = s;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.final(progressOf(sim, totalSteps, duration, rate(sim, wall), particles), "finished");
  if (sink)
    if (Status s = sink->close(); !s.isOk() && run.isOk()) run = s;
  run = all.agree(run);
  spdlog::info("rank {}: {}", rank, sim.timers().report());
  if (!run.isOk()) return fail(run.code() == StatusCode::kIo || run.code() == StatusCode::kUnavailable ? 2 : 3, run.message());
  if (lead) spdlog::info("job {} finished: {} steps in {:.1f} s", o.jobId, sim.stepCount(), wall);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Device indices in a lease come from NVML, which numbers GPUs by PCI bus; make CUDA number them alike.
  setenv("CUDA_DEVICE_ORDER", "PCI_BUS_ID", 0);
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);

  CLI::App app{"pflow-worker: the MPI compute program of a pflow job"};
  worker::WorkerOptions o;
  std::string devices, logLevel = "info";
  app.add_option("--job-id", o.jobId, "job id")->required();
  app.add_option("--model", o.modelDir, "built model folder (scene.yaml and its files)")->required();
  app.add_option("--manager", o.managerAddress, "manager host:port for progress reports and cancel");
  app.add_option("--backend", o.backendAddress, "back-end host:port for snapshots");
  app.add_option("--output", o.output, "local HDF5 file for snapshots when no back-end is given");
  app.add_option("--devices", devices, "leased devices in rank order: node:gpu|cpu:index,... (or slurm:gpu|slurm:cpu under srun)")->required();
  app.add_option("--progress-interval", o.progressInterval, "seconds between progress reports")->capture_default_str();
  app.add_option("--threads", o.threads, "OpenMP threads per rank (0: all)");
  app.add_option("--spool-bytes", o.spoolBytes, "output kept while the back-end is away before output pauses [bytes]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--spool-wait", o.spoolCloseWait, "at the end, seconds to wait for the back-end to take the spool")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--checkpoint-wall", o.checkpointWallSeconds,
                 "seconds of wall clock between checkpoints sent to the back-end (0: only the scene's output.checkpoint_interval)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--attempt", o.attempt, "the job's attempt (the agent passes the lease's after a requeue)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_flag("--resume", o.resume, "go on from the job's last checkpoint on the back-end (the agent passes it when the job was requeued)");
  app.add_option("--log-level", logLevel, "trace, debug, info, warn, error")->capture_default_str();
  rpc::TransportFlags transportFlags;  // the agent passes its own: each rank presents its own node's certificate
  transportFlags.add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    MPI_Finalize();
    return code == 0 ? 0 : 1;
  }
  pflow::log::init("worker." + std::to_string(rank), logLevel);
  std::signal(SIGTERM, onStopSignal);
  std::signal(SIGINT, onStopSignal);

  int code = 0;
  Result<std::vector<worker::LeasedDevice>> parsed = devices.rfind("slurm:", 0) == 0 ? slurmDevices(devices.substr(6), rank, size)
                                                                                     : worker::parseDevices(devices);
  if (!parsed) code = fail(1, parsed.status().message());
  else if (int(parsed.value().size()) != size)
    code = fail(1, "--devices lists " + std::to_string(parsed.value().size()) + " device(s) for " + std::to_string(size) + " rank(s)");
  else if (o.backendAddress.empty() && o.output.empty()) code = fail(1, "give --backend or --output for the snapshots");
  else o.devices = parsed.value();
  if (code == 0 && (!o.managerAddress.empty() || !o.backendAddress.empty())) {
    auto transport = transportFlags.resolve("node-" + o.devices[std::size_t(rank)].node);  // the node this rank runs on
    if (!transport) code = fail(1, transport.status().message());
    else rpc::setDefaultTransport(transport.value());
  }

  // Option errors are the same on every rank (same command line).
  if (code == 0) code = runRank(o, rank, size);
  if (code < 0) code = -1 - code;  // stopped: 0 when the manager cancelled, 143 when a signal came from elsewhere
  MPI_Finalize();
  return code;
}
