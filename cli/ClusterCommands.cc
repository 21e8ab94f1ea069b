#include "cli/ClusterCommands.h"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "backend/BackendClient.h"
#include "cli/RunCommand.h"
#include "common/rpc/Rpc.h"
#include "frontend/SceneLoader.h"
#include "manager/JobJson.h"
#include "pflow/manager/v1/manager_service.grpc.pb.h"

namespace pflow::cli {

namespace fs = std::filesystem;
namespace mv1 = pflow::manager::v1;
using nlohmann::json;

namespace {

using manager::stateName;
using manager::toJson;

std::string configValue(const std::string& key) {
  std::string path;
  if (const char* p = std::getenv("PFLOW_CONFIG")) path = p;
  else if (const char* home = std::getenv("HOME")) path = std::string(home) + "/.config/pflow/config.yaml";
  if (path.empty() || !fs::exists(path)) return {};
  try {
    const YAML::Node n = YAML::LoadFile(path);
    if (n[key] && n[key].IsScalar()) return n[key].Scalar();
  } catch (const YAML::Exception& ex) {
    std::fprintf(stderr, "pflow: ignoring %s: %s\n", path.c_str(), ex.what());
  }
  return {};
}

std::string resolveOne(const std::string& flag, const char* env, const std::string& key, const char* fallback) {
  if (!flag.empty()) return flag;
  if (const char* v = std::getenv(env); v && *v) return v;
  if (std::string c = configValue(key); !c.empty()) return c;
  return fallback;
}

int report(const grpc::Status& s, const std::string& what, const std::string& address) {
  Status st = rpc::fromGrpc(s, what);
  if (s.error_code() == grpc::StatusCode::UNAVAILABLE || s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)
    st = Status(st.code(), what + ": cannot reach " + address + " (" + s.error_message() +
                               "); is the service running? Set the address with --manager/--backend, PFLOW_MANAGER/PFLOW_BACKEND or "
                               "~/.config/pflow/config.yaml");
  std::fprintf(stderr, "pflow: %s\n", st.message().c_str());
  return exitCodeFor(st);
}

std::unique_ptr<mv1::ManagerService::Stub> manager(const Endpoints& e) {
  return mv1::ManagerService::NewStub(rpc::makeChannel(e.manager));
}

bool finished(mv1::JobState s) {
  return s == mv1::JOB_STATE_SUCCEEDED || s == mv1::JOB_STATE_FAILED || s == mv1::JOB_STATE_CANCELLED;
}

std::string devicesText(const mv1::Job& j) {
  std::string out;
  for (const auto& d : j.devices()) {
    if (!out.empty()) out += ",";
    out += d.node() + ":" + (d.kind() == common::v1::DEVICE_KIND_GPU ? "gpu" : "cpu") + std::to_string(d.index());
  }
  return out.empty() ? "-" : out;
}

std::string duration(double s) {
  if (!(s > 0)) return "-";
  char buf[32];
  if (s < 120) std::snprintf(buf, sizeof buf, "%.0fs", s);
  else if (s < 7200) std::snprintf(buf, sizeof buf, "%.1fmin", s / 60);
  else std::snprintf(buf, sizeof buf, "%.1fh", s / 3600);
  return buf;
}

// "2/3": the attempt (a start; more than one after a requeue) and the job's limit; "-" before the first start.
std::string attemptText(const mv1::Job& j) {
  if (j.attempts() == 0) return "-";
  return std::to_string(j.attempts()) + (j.max_attempts() > 0 ? "/" + std::to_string(j.max_attempts()) : "");
}

double percent(const mv1::Job& j) {
  const auto& p = j.progress();
  return p.total_steps() > 0 ? 100.0 * double(p.step()) / double(p.total_steps()) : 0.0;
}

int exitForFinalState(const mv1::Job& j) {
  switch (j.state()) {
    case mv1::JOB_STATE_SUCCEEDED: return kExitOk;
    case mv1::JOB_STATE_CANCELLED: return kExitCancelled;
    default: return kExitSimulation;
  }
}

void printJob(const mv1::Job& j) {
  std::printf("job %s (%s): %s%s%s\n", j.id().c_str(), j.name().c_str(), stateName(j.state()), j.reason().empty() ? "" : ": ",
              j.reason().c_str());
  std::printf("  particles  %llu on %s\n", (unsigned long long)j.particles(), devicesText(j).c_str());
  if (j.attempts() > 1 || j.state() == mv1::JOB_STATE_REQUEUED)
    std::printf("  attempt    %s (a lost node or a killed worker puts a job back in the queue)\n", attemptText(j).c_str());
  const auto& p = j.progress();
  std::printf("  progress   step %lld / %lld (%.1f%%), t = %.4g / %.4g s, %.3g particle-steps/s, ETA %s\n", (long long)p.step(),
              (long long)p.total_steps(), percent(j), p.time(), p.duration(), p.particle_steps_per_second(), duration(p.eta_seconds()).c_str());
  std::printf("  model      %s\n", j.model_uri().c_str());
  if (!j.slurm_job_id().empty()) std::printf("  slurm job  %s (squeue -j %s)\n", j.slurm_job_id().c_str(), j.slurm_job_id().c_str());
  if (!j.model().empty()) std::printf("  computes (the least model the scene needs):\n%s", j.model().c_str());
}

}  // namespace

Status Endpoints::resolve() {
  manager = resolveOne(manager, "PFLOW_MANAGER", "manager", "127.0.0.1:50051");
  backend = resolveOne(backend, "PFLOW_BACKEND", "backend", "127.0.0.1:50053");
  token = resolveOne("", "PFLOW_TOKEN", "token", "");
  if (!insecure) insecure = resolveOne("", "PFLOW_INSECURE", "insecure", "") == "1" || configValue("insecure") == "true";
  ca = resolveOne(ca, "PFLOW_CA", "ca", "");
  if (insecure && !(rpc::isLoopbackHost(rpc::hostOf(manager)) && rpc::isLoopbackHost(rpc::hostOf(backend))))
    return invalidArgument("--insecure talks plaintext, and would send the token in the clear: only to services on loopback (" + manager +
                           ", " + backend + " are not)");
  rpc::setCallToken(token);
  if (insecure) {
    rpc::setDefaultTransport(rpc::Transport::plaintext());
    return Status::ok();
  }
  if (ca.empty())
    return invalidArgument("no pflow CA to verify the services with: give --ca FILE, PFLOW_CA or `ca:` in ~/.config/pflow/config.yaml "
                           "(deploy/local/start.sh writes one), or --insecure for a stack started with --insecure");
  auto transport = rpc::Transport::caOnly(ca);
  if (!transport) return transport.status();
  rpc::setDefaultTransport(transport.value());
  return Status::ok();
}

int manageUsers(const Endpoints& e, const UserOptions& o, bool asJson) {
  auto stub = manager(e);
  auto ctx = rpc::contextWithDeadline();
  grpc::Status s;
  if (o.action == "list") {
    mv1::ListUsersResponse resp;
    s = stub->ListUsers(ctx.get(), mv1::ListUsersRequest(), &resp);
    if (!s.ok()) return report(s, "list users", e.manager);
    if (asJson) {
      json out = json::array();
      for (const auto& u : resp.users()) out.push_back({{"name", u.name()}, {"admin", u.admin()}, {"created_at", u.created_at()}});
      std::printf("%s\n", out.dump().c_str());
    } else {
      std::printf("%-24s %s\n", "NAME", "ADMIN");
      for (const auto& u : resp.users()) std::printf("%-24s %s\n", u.name().c_str(), u.admin() ? "yes" : "no");
    }
    return 0;
  }
  if (o.action == "remove") {
    mv1::RemoveUserRequest req;
    req.set_name(o.name);
    mv1::RemoveUserResponse resp;
    s = stub->RemoveUser(ctx.get(), req, &resp);
    if (!s.ok()) return report(s, "remove user " + o.name, e.manager);
    std::printf(asJson ? "{\"removed\":\"%s\"}\n" : "removed user %s\n", o.name.c_str());
    return 0;
  }
  mv1::UserTokenResponse resp;
  if (o.action == "add") {
    mv1::AddUserRequest req;
    req.set_name(o.name);
    req.set_admin(o.admin);
    s = stub->AddUser(ctx.get(), req, &resp);
  } else {
    mv1::RotateTokenRequest req;
    req.set_name(o.name);
    s = stub->RotateToken(ctx.get(), req, &resp);
  }
  if (!s.ok()) return report(s, o.action + " user " + o.name, e.manager);
  if (asJson) std::printf("%s\n", json{{"name", resp.name()}, {"token", resp.token()}}.dump().c_str());
  else
    std::printf("token of %s (shown once; give it to them, e.g. as PFLOW_TOKEN or `token:` in ~/.config/pflow/config.yaml):\n%s\n",
                resp.name().c_str(), resp.token().c_str());
  return 0;
}

int submitJob(const Endpoints& e, const SubmitOptions& o, bool json) {
  // Validate here first: the user sees every error with line and column before anything is sent.
  auto scene = frontend::loadScene(o.scenePath);
  if (!scene) {
    std::fprintf(stderr, "%s\n", scene.status().message().c_str());
    return exitCodeFor(scene.status());
  }
  mv1::SubmitJobRequest req;
  std::ifstream in(o.scenePath, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  req.set_scene_yaml(text.str());
  req.set_scene_name(fs::path(o.scenePath).filename().string());
  req.set_name(o.name.empty() ? fs::path(o.scenePath).stem().string() : o.name);
  req.set_wait(o.wait);
  req.set_max_devices(o.maxDevices);
  const fs::path dir = fs::path(o.scenePath).parent_path();
  for (const std::string& f : scene.value().files) {
    std::ifstream fin(dir / f, std::ios::binary);
    std::stringstream bytes;
    bytes << fin.rdbuf();
    if (!fin) {
      std::fprintf(stderr, "pflow: cannot read '%s', which the scene refers to\n", (dir / f).string().c_str());
      return kExitIo;
    }
    auto* a = req.add_files();
    a->set_path(f);
    a->set_content(bytes.str());
  }
  mv1::SubmitJobResponse resp;
  auto stub = manager(e);
  auto ctx = rpc::contextWithDeadline(120);  // a manager without a build queue builds the model before answering
  if (grpc::Status s = stub->SubmitJob(ctx.get(), req, &resp); !s.ok()) return report(s, "submit", e.manager);
  // The manager answers at once with the job BUILDING; it is QUEUED (or FAILED: the scene's errors, or refused) when
  // the frontend has built it.
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(int(rpc::kBulkDeadlineSeconds));
  while (resp.job().state() == mv1::JOB_STATE_BUILDING && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    mv1::GetJobRequest get;
    get.set_id(resp.job().id());
    mv1::Job job;
    if (grpc::Status s = rpc::retryIdempotent([&](grpc::ClientContext* c) { return stub->GetJob(c, get, &job); }); !s.ok())
      return report(s, "submit: job " + get.id(), e.manager);
    *resp.mutable_job() = job;
  }
  if (resp.job().state() == mv1::JOB_STATE_FAILED && resp.job().finished_at() > 0 && resp.job().started_at() == 0) {
    const std::string& why = resp.job().reason();
    std::fprintf(stderr, "pflow: submit: job %s: %s\n", resp.job().id().c_str(), why.c_str());
    return why.rfind("refused: ", 0) == 0 ? kExitRefused : kExitInvalid;  // refused, or the scene's errors
  }
  if (json && !o.watch) std::printf("%s\n", toJson(resp.job()).dump().c_str());
  else if (!json) std::printf("submitted job %s (%s): %s, %llu particles\n", resp.job().id().c_str(), resp.job().name().c_str(),
                              stateName(resp.job().state()), (unsigned long long)resp.job().particles());
  if (o.watch) return watchJob(e, resp.job().id(), json);
  return kExitOk;
}

int listJobs(const Endpoints& e, bool all, bool json) {
  mv1::ListJobsRequest req;
  req.set_active_only(!all);
  mv1::ListJobsResponse resp;
  auto stub = manager(e);
  if (grpc::Status s = rpc::retryIdempotent([&](grpc::ClientContext* ctx) { return stub->ListJobs(ctx, req, &resp); }); !s.ok())
    return report(s, "jobs", e.manager);
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& j : resp.jobs()) out.push_back(toJson(j));
    std::printf("%s\n", out.dump().c_str());
    return kExitOk;
  }
  std::printf("%-18s %-16s %-10s %7s %10s %-22s %7s %10s %8s\n", "ID", "NAME", "STATE", "ATTEMPT", "PARTICLES", "DEVICES", "DONE", "RATE",
              "ETA");
  for (const auto& j : resp.jobs())
    std::printf("%-18s %-16s %-10s %7s %10llu %-22s %6.1f%% %10.3g %8s\n", j.id().c_str(), j.name().substr(0, 16).c_str(), stateName(j.state()),
                attemptText(j).c_str(), (unsigned long long)j.particles(), devicesText(j).substr(0, 22).c_str(), percent(j),
                j.progress().particle_steps_per_second(), finished(j.state()) ? "-" : duration(j.progress().eta_seconds()).c_str());
  if (resp.jobs().empty()) std::printf("(no %sjobs)\n", all ? "" : "active ");
  return kExitOk;
}

int showJob(const Endpoints& e, const std::string& id, bool json) {
  mv1::GetJobRequest req;
  req.set_id(id);
  mv1::Job job;
  auto stub = manager(e);
  if (grpc::Status s = rpc::retryIdempotent([&](grpc::ClientContext* ctx) { return stub->GetJob(ctx, req, &job); }); !s.ok())
    return report(s, "job " + id, e.manager);
  if (json) std::printf("%s\n", toJson(job).dump().c_str());
  else printJob(job);
  return kExitOk;
}

int listNodes(const Endpoints& e, bool json) {
  mv1::ListNodesResponse resp;
  auto stub = manager(e);
  if (grpc::Status s = rpc::retryIdempotent([&](grpc::ClientContext* ctx) { return stub->ListNodes(ctx, mv1::ListNodesRequest(), &resp); });
      !s.ok())
    return report(s, "nodes", e.manager);
  auto stateOf = [](mv1::DeviceState st) { return st == mv1::DEVICE_STATE_FREE ? "free" : st == mv1::DEVICE_STATE_BUSY ? "busy" : st == mv1::DEVICE_STATE_LOST ? "lost" : "?"; };
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& n : resp.nodes()) out.push_back(manager::toJson(n));
    std::printf("%s\n", out.dump().c_str());
    return kExitOk;
  }
  std::printf("%-14s %-8s %-30s %-6s %17s %6s %6s %s\n", "NODE", "DEVICE", "NAME", "STATE", "MEMORY USED/TOTAL", "LOAD", "TEMP", "JOB");
  for (const auto& n : resp.nodes())
    for (const auto& d : n.devices()) {
      char mem[32], temp[16];
      std::snprintf(mem, sizeof mem, "%.1f/%.1f GiB", double(d.memory_used_bytes()) / (1 << 30), double(d.memory_total_bytes()) / (1 << 30));
      std::snprintf(temp, sizeof temp, d.temperature_c() > 0 ? "%.0fC" : "-", d.temperature_c());
      const std::string dev = std::string(d.ref().kind() == common::v1::DEVICE_KIND_GPU ? "gpu" : "cpu") + std::to_string(d.ref().index());
      std::printf("%-14s %-8s %-30s %-6s %17s %5.0f%% %6s %s\n", n.name().c_str(), dev.c_str(), d.name().substr(0, 30).c_str(),
                  n.lost() ? "lost" : stateOf(d.state()), mem, 100 * d.utilization(), temp, d.job_id().empty() ? "-" : d.job_id().c_str());
    }
  for (const auto& n : resp.nodes())  // placement through Slurm: the node's own state, as Slurm says it
    if (!n.slurm_state().empty())
      std::printf("%s: Slurm state %s%s, CPU load %.2f\n", n.name().c_str(), n.slurm_state().c_str(),
                  n.slurm_reason().empty() ? "" : (" (" + n.slurm_reason() + ")").c_str(), n.cpu_load());
  if (resp.nodes().empty()) std::printf("(no nodes: start a pflow-agent, or check the manager's Slurm partition)\n");
  return kExitOk;
}

int cancelJob(const Endpoints& e, const std::string& id, bool json) {
  mv1::CancelJobRequest req;
  req.set_id(id);
  mv1::Job job;
  auto ctx = rpc::contextWithDeadline();
  if (grpc::Status s = manager(e)->CancelJob(ctx.get(), req, &job); !s.ok()) return report(s, "cancel " + id, e.manager);
  if (json) std::printf("%s\n", toJson(job).dump().c_str());
  else std::printf("job %s: %s\n", job.id().c_str(), stateName(job.state()));
  return kExitOk;
}

int deleteJob(const Endpoints& e, const std::string& id, bool json) {
  mv1::DeleteJobRequest req;
  req.set_id(id);
  mv1::DeleteJobResponse resp;
  auto ctx = rpc::contextWithDeadline(60);  // the back-end deletes the job's files first
  if (grpc::Status s = manager(e)->DeleteJob(ctx.get(), req, &resp); !s.ok()) return report(s, "delete " + id, e.manager);
  if (json) std::printf("%s\n", json::object({{"deleted", id}}).dump().c_str());
  else std::printf("job %s deleted, with its snapshots and checkpoints\n", id.c_str());
  return kExitOk;
}

int watchJob(const Endpoints& e, const std::string& id, bool json) {
  mv1::WatchJobRequest req;
  req.set_id(id);
  grpc::ClientContext ctx;  // no deadline: a watch lasts as long as the job (the stream ends with it)
  rpc::addBearer(ctx, e.token);
  auto stub = manager(e);
  auto reader = stub->WatchJob(&ctx, req);
  mv1::JobEvent ev;
  const bool tty = ::isatty(fileno(stdout));
  mv1::Job last;
  bool any = false;
  while (reader->Read(&ev)) {
    any = true;
    last = ev.job();
    if (json) {
      auto j = toJson(last);
      j["message"] = ev.message();
      std::printf("%s\n", j.dump().c_str());
      std::fflush(stdout);
      continue;
    }
    const double pc = percent(last);
    const int width = 30, filled = int(std::lround(pc / 100 * width));
    std::string bar(std::size_t(std::clamp(filled, 0, width)), '#');
    bar.resize(width, '.');
    std::printf("%s%-10s [%s] %5.1f%%  t = %.4g s  %.3g particle-steps/s  ETA %s%s", tty ? "\r" : "", stateName(last.state()), bar.c_str(), pc,
                last.progress().time(), last.progress().particle_steps_per_second(), duration(last.progress().eta_seconds()).c_str(),
                tty ? "   " : "\n");
    std::fflush(stdout);
  }
  const grpc::Status s = reader->Finish();
  if (!json && tty) std::printf("\n");
  if (!s.ok()) return report(s, "watch " + id, e.manager);
  if (!any) return kExitOk;
  if (!json) {
    std::printf("job %s %s", last.id().c_str(), stateName(last.state()));
    if (!last.reason().empty()) std::printf(": %s", last.reason().c_str());
    std::printf("\n");
  }
  return exitForFinalState(last);
}

int fetchSnapshot(const Endpoints& e, const FetchOptions& o, bool json) {
  auto client = backend::makeGrpcBackendClient(e.backend);
  const std::string csv = backend::probesCsvPathFor(o.output);
  std::error_code ec;
  if (o.probes) fs::remove(csv, ec);  // replaced like the output file: a leftover would pass for this job's
  const Status s = client->fetch(o.jobId, o.step, o.output, o.fields, o.grid, o.geometry, o.probes);
  if (!s.isOk()) {
    std::string msg = s.message();
    if (s.code() == StatusCode::kUnavailable || s.code() == StatusCode::kDeadlineExceeded)
      msg = "fetch: cannot reach the back-end at " + e.backend + " (" + msg + "); set it with --backend, PFLOW_BACKEND or ~/.config/pflow/config.yaml";
    std::fprintf(stderr, "pflow: %s\n", msg.c_str());
    return exitCodeFor(s);
  }
  const std::string xmf = fs::path(o.output).replace_extension(".xmf").string();
  const bool probes = o.probes && fs::exists(csv, ec);  // the fetch wrote it (an SPH job with probes)
  if (json) {
    nlohmann::json j{{"job", o.jobId}, {"output", o.output}, {"xdmf", xmf}};
    if (probes) j["probes_csv"] = csv;
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("job %s: snapshot written to %s (open %s in ParaView)\n", o.jobId.c_str(), o.output.c_str(), xmf.c_str());
    if (probes) std::printf("job %s: time series (an SPH run's probes, a DEM run's energy, contacts and wall loads) in %s (/probes) and %s\n", o.jobId.c_str(), o.output.c_str(), csv.c_str());
  }
  return kExitOk;
}

}  // namespace pflow::cli
