// The SPH job loop of pflow-worker (solver: sph): DEM's runRank (main.cc) with compute::sph::SphSimulation,
// whose step varies (progress and outputs go by simulated time), and the scene's probes and gauges sampled every
// sph probe interval (else at each snapshot) and sent to the sink after each snapshot and at the end.
#include <mpi.h>

#include <chrono>
#include <cmath>

#include "compute/mpi/MpiDomain.h"
#include "compute/sph/SphSimulation.h"
#include "compute/worker/SnapshotSinks.h"
#include "compute/worker/JobCheckpoints.h"
#include "compute/worker/WorkerRun.h"

namespace pflow::worker {

namespace {

using compute::sph::SphSimulation;

// The step count to the end is not known in advance (the CFL step follows the flow): the estimate is the steps
// so far scaled to the duration.
manager::v1::Progress sphProgress(const SphSimulation& sim, double duration, double rate, double wall) {
  manager::v1::Progress p;
  const double done = duration > 0 ? sim.time() / duration : 1;
  const auto estimate = done > 0 ? std::int64_t(std::llround(double(sim.stepCount()) / done)) : sim.stepCount();
  p.set_step(sim.stepCount());
  p.set_total_steps(std::max(estimate, sim.stepCount()));
  p.set_time(sim.time());
  p.set_duration(duration);
  p.set_particle_steps_per_second(rate);
  p.set_eta_seconds(done > 0 ? wall / done * (1 - done) : 0);
  return p;
}

}  // namespace

int runSphRank(const WorkerOptions& o, int rank, int ranks, const frontend::LoadedScene& scene) {
  const bool lead = rank == 0;
  compute::RunConfig cfg = scene.config;
  if (o.threads > 0) cfg.sim.threads = o.threads;
  const LeasedDevice& device = o.devices[std::size_t(rank)];
  const RankPlacement place = placeRank(o, rank, ranks, cfg);
  compute::sph::SphOptions so;
  so.executor = place.executor;
  so.device = place.device;
  const auto& domain = place.domain;
  so.domain = domain;
  compute::Domain single;
  compute::Domain& all = domain ? static_cast<compute::Domain&>(*domain) : single;
  auto created = SphSimulation::create(cfg, so);
  if (!created) return fail(created.status().code() == StatusCode::kInvalidArgument ? 1 : 3, created.status().message());
  SphSimulation& sim = *created.value();
  const double particles = double(sim.totalParticles());
  const std::string executorNote = "SPH, " + sim.executorDescription() + ", " + sim.precisionName() + " (device " + device.node + ":" +
                                   device.kind + ":" + std::to_string(device.index) + "; " + std::to_string(ranks) + " rank(s))";
  spdlog::info("job {}: rank {} of {}: {} of {} SPH particles ({} fluid), executor {}", o.jobId, rank, ranks, sim.numParticles(), particles,
               sim.fluidParticles(), executorNote);
  JobCheckpoints checkpoints(o, "sph", sim.precisionName(), scene.checkpointInterval, lead, all);
  auto resumed = checkpoints.resume(sim);
  if (!resumed) return fail(3, "resuming from the job's checkpoint: " + resumed.status().message());
  const std::int64_t firstStep = sim.stepCount();

  std::unique_ptr<SnapshotSink> sink;
  Status opened;
  if (lead) {
    auto made = o.backendAddress.empty() ? makeFileSink(o.output) : makeBackendSink(o);
    if (made) sink = std::move(made).value();
    else opened = made.status();
    if (opened.isOk()) opened = sink->writeGeometry({});
  }
  if (Status s = all.agree(opened); !s.isOk()) return fail(2, s.message());
  checkpoints.setOutputsDelivered([&] { return !sink || sink->delivered(); });
  const auto& fields = scene.outputFields;

  // Probes: sampled on every rank (a collective), kept and sent by rank 0.
  backend::ProbeRecorder probes(sim, cfg.sph.probeInterval, cfg.sph.probeMean);
  std::size_t sent = 0;  // samples already with the sink
  auto sendProbes = [&]() -> Status {  // rank 0's samples since the last send
    const backend::ProbeSeries& series = probes.series();
    if (!lead || probes.empty() || sent == series.time.size()) return Status::ok();
    Status s = sink->writeProbes(backend::probeSamples(series, sent));
    if (s.isOk()) sent = series.time.size();
    return s;
  };
  auto write = [&]() -> Status {  // collective: every rank's particles gathered on rank 0
    auto t = sim.timers().time(compute::Phase::kOutput);
    compute::ParticleSnapshot snap = sim.snapshot(fields);
    Status s = lead ? sink->write(snap) : Status::ok();
    if (s.isOk()) s = sendProbes();
    return all.agree(s);
  };
  if (!resumed.value())  // a resumed run's snapshot of this step is on the back-end already
    if (Status s = write(); !s.isOk()) return fail(2, s.message());

  const double duration = cfg.sim.duration;
  sim.scheduleOutput(cfg.sim.snapshotInterval, duration);
  ProgressReporter progress(lead ? o.managerAddress : std::string(), o.jobId, o.progressInterval, o.attempt);
  const auto start = std::chrono::steady_clock::now();
  auto lastPost = start - std::chrono::hours(1);
  bool cancelled = false;
  int stopWhy = 0;
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  auto rate = [&](const SphSimulation& s, double wall) { return wall > 0 ? particles * double(s.stepCount() - firstStep) / wall : 0; };
  auto observer = [&](const SphSimulation& s) -> Status {
    probes.sample(s);  // collective
    if (s.outputDue())
      if (Status st = write(); !st.isOk()) return st;
    checkpoints.maybeTake(s, sim.timers());
    if ((stopWhy = stopAgreed(progress.cancelRequested(), domain)) != 0) {
      cancelled = true;
      return Status(StatusCode::kCancelled, "cancelled at step " + std::to_string(s.stepCount()));
    }
    const auto now = std::chrono::steady_clock::now();
    if (lead && std::chrono::duration<double>(now - lastPost).count() >= o.progressInterval) {
      lastPost = now;
      const double wall = seconds();
      progress.post(sphProgress(s, duration, rate(s, wall), wall), executorNote);
    }
    return Status::ok();
  };
  Status run = sim.runUntil(duration, observer);
  // What was measured reaches the sink also when the run failed or was cancelled.
  if (sink)
    if (Status s = sendProbes(); !s.isOk()) spdlog::warn("probe series: {}", s.message());
  if (cancelled) {
    spdlog::info("job {} cancelled at step {} (t = {} s)", o.jobId, sim.stepCount(), sim.time());
    if (sink)
      if (Status s = sink->close(); !s.isOk()) spdlog::warn("{}", s.message());
    return -1 - stoppedExitCode(stopWhy);
  }
  const double wall = seconds();
  progress.final(sphProgress(sim, duration, rate(sim, wall), wall), "finished");
  if (sink)
    if (Status s = sink->close(); !s.isOk() && run.isOk()) run = s;
  run = all.agree(run);
  spdlog::info("rank {}: {}", rank, sim.timers().report());
  if (!run.isOk()) return fail(run.code() == StatusCode::kIo || run.code() == StatusCode::kUnavailable ? 2 : 3, run.message());
  if (lead) spdlog::info("job {} finished: {} steps to t = {} s in {:.1f} s", o.jobId, sim.stepCount(), sim.time(), wall);
  return 0;
}

}  // namespace pflow::worker
