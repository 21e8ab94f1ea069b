#include "frontend/service/FrontendService.h"

#include <filesystem>

#include "common/Log.h"
#include "common/rpc/Rpc.h"
#include "frontend/SceneSummary.h"

namespace pflow::frontend {

namespace {

constexpr std::size_t kMaxSceneBytes = 64u << 20;

// The scene's slurm: section, for the manager's --placement slurm.
void slurmToProto(const SlurmRequest& r, v1::SceneSummary* out) {
  out->set_slurm_partition(r.partition);
  out->set_slurm_account(r.account);
  out->set_slurm_time_limit(r.timeLimit);
}

void toProto(const SceneSummary& s, double duration, v1::SceneSummary* out) {
  out->set_particles(s.particles);
  out->set_min_radius(s.minRadius);
  out->set_max_radius(s.maxRadius);
  out->set_solid_volume(s.solidVolume);
  for (const auto& set : s.sets) {
    auto* p = out->add_sets();
    p->set_name(set.info.name);
    p->set_method(set.info.method);
    p->set_count(set.info.count);
    p->set_min_radius(set.info.minRadius);
    p->set_max_radius(set.info.maxRadius);
    p->set_solid_fraction(set.solidFraction);
  }
  for (const auto& f : s.surfaces) {
    auto* p = out->add_surfaces();
    p->set_id(f.id);
    p->set_name(f.name);
    p->set_triangles(f.triangles);
    p->set_area(f.area);
  }
  out->set_triangles(s.triangles);
  auto* lo = out->mutable_domain()->mutable_min();
  lo->set_x(s.domain.lo.x), lo->set_y(s.domain.lo.y), lo->set_z(s.domain.lo.z);
  auto* hi = out->mutable_domain()->mutable_max();
  hi->set_x(s.domain.hi.x), hi->set_y(s.domain.hi.y), hi->set_z(s.domain.hi.z);
  out->set_dt(s.dt);
  out->set_dt_reason(s.dtReason);
  for (const auto& w : s.warnings) out->add_warnings(w);
  out->set_steps(s.steps);
  out->set_duration(duration);
  out->set_memory_bytes(s.memoryBytes);
  out->set_model(s.model.text());
  out->set_solver(s.solver);
}

// Scene-level errors ("line L, column C: path: message" lines of the loader) as FieldErrors.
void errorsToProto(const Status& s, google::protobuf::RepeatedPtrField<common::v1::FieldError>* out) {
  std::size_t start = 0;
  const std::string& m = s.message();
  bool first = true;
  while (start < m.size()) {
    std::size_t end = m.find('\n', start);
    if (end == std::string::npos) end = m.size();
    std::string line = m.substr(start, end - start);
    start = end + 1;
    if (first && line.find(" error(s)") != std::string::npos) {  // the header line
      first = false;
      continue;
    }
    first = false;
    auto* e = out->Add();
    int l = 0, c = 0;
    char rest = 0;
    if (std::sscanf(line.c_str(), "line %d, column %d:%c", &l, &c, &rest) == 3) {
      e->set_line(l);
      e->set_column(c);
      line = line.substr(line.find(':') + 2);
    }
    const auto colon = line.find(": ");
    if (colon != std::string::npos && line.find(' ') >= colon) {
      e->set_path(log::utf8Escaped(line.substr(0, colon)));
      e->set_message(log::utf8Escaped(line.substr(colon + 2)));
    } else {
      e->set_message(log::utf8Escaped(line));
    }
  }
}

struct Loaded {
  std::string stagingDir;
  std::vector<SceneFile> files;
  Result<LoadedScene> scene = invalidArgument("not loaded");
};

// Stages the attached files and loads the scene against them. A request error is a non-OK Status.
Status loadRequest(ModelStore& store, const std::string& yaml, const std::string& name,
                   const google::protobuf::RepeatedPtrField<common::v1::AttachedFile>& attached, Loaded& out) {
  if (yaml.empty()) return invalidArgument("scene_yaml is empty");
  std::size_t bytes = yaml.size();
  for (const auto& f : attached) {
    bytes += f.content().size();
    out.files.push_back({f.path(), f.content()});
  }
  if (bytes > kMaxSceneBytes) return invalidArgument("the scene and its files are " + std::to_string(bytes) + " bytes; the limit is 64 MiB");
  auto staged = store.stage(out.files);
  if (!staged) return staged.status();
  out.stagingDir = staged.value();
  LoadOptions options;
  options.baseDir = out.stagingDir;
  options.confineFiles = true;  // the scene's own upload, nothing else on this host
  options.maxFileBytes = kMaxSceneBytes;
  out.scene = loadSceneFromString(yaml, name.empty() ? "scene.yaml" : name, options);
  if (!out.scene) {  // the files as the client named them, not by this host's staging directory
    std::string m = out.scene.status().message();
    const std::string staging = out.stagingDir + "/";
    for (std::size_t at; (at = m.find(staging)) != std::string::npos;) m.erase(at, staging.size());
    out.scene = Status(out.scene.status().code(), std::move(m));
  }
  return Status::ok();
}

void removeStaging(const Loaded& l) {
  std::error_code ec;
  if (!l.stagingDir.empty()) std::filesystem::remove_all(l.stagingDir, ec);
}

}  // namespace

Status FrontendServiceImpl::validate(const v1::ValidateSceneRequest& req, v1::ValidateSceneResponse* resp) {
  Loaded l;
  Status s = loadRequest(m_store, req.scene_yaml(), req.scene_name(), req.files(), l);
  if (s.isOk()) {
    if (!l.scene) {
      resp->set_valid(false);
      errorsToProto(l.scene.status(), resp->mutable_errors());
    } else if (auto summary = summarize(l.scene.value()); !summary) {
      resp->set_valid(false);
      errorsToProto(summary.status(), resp->mutable_errors());
    } else {
      resp->set_valid(true);
      toProto(summary.value(), l.scene.value().config.sim.duration, resp->mutable_summary());
      slurmToProto(l.scene.value().slurm, resp->mutable_summary());
    }
  }
  removeStaging(l);
  return s;
}

Status FrontendServiceImpl::build(const v1::BuildSceneRequest& req, v1::BuildSceneResponse* resp) {
  Loaded l;
  Status s = loadRequest(m_store, req.scene_yaml(), req.scene_name(), req.files(), l);
  if (s.isOk() && !l.scene) s = failedPrecondition(l.scene.status().message());
  Result<SceneSummary> summary = invalidArgument("");
  if (s.isOk()) {
    summary = summarize(l.scene.value());
    if (!summary) s = failedPrecondition(summary.status().message());
  }
  if (s.isOk()) {
    auto stored = m_store.put(req.scene_yaml(), l.files, l.scene.value(), toJson(summary.value()));
    if (!stored) {
      s = stored.status();
    } else {
      resp->set_model_id(stored.value().id);
      resp->set_model_uri(stored.value().dir);
      toProto(summary.value(), l.scene.value().config.sim.duration, resp->mutable_summary());
      slurmToProto(l.scene.value().slurm, resp->mutable_summary());
      spdlog::info("built model {} ({} particles) from {}", stored.value().id, summary.value().particles, log::escaped(req.scene_name()));
    }
  }
  removeStaging(l);
  return s;
}

// Runs `work` on the pool (never on gRPC's threads) unless the caller is not the manager or its deadline has
// passed by the time a worker is free.
template <class Work>
grpc::ServerUnaryReactor* FrontendServiceImpl::onPool(grpc::CallbackServerContext* ctx, const char* what, Work work) {
  auto* reactor = ctx->DefaultReactor();
  if (Status who = rpc::requirePeer(*ctx, "the frontend", rpc::kManagerIdentity); !who) {
    reactor->Finish(rpc::toGrpc(who));
    return reactor;
  }
  m_pool->post([ctx, reactor, what, work = std::move(work)]() mutable {
    if (ctx->IsCancelled())
      reactor->Finish(grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, std::string(what) + " waited past its deadline"));
    else
      reactor->Finish(rpc::toGrpc(work()));
  });
  return reactor;
}

grpc::ServerUnaryReactor* FrontendServiceImpl::ValidateScene(grpc::CallbackServerContext* ctx, const v1::ValidateSceneRequest* req,
                                                             v1::ValidateSceneResponse* resp) {
  return onPool(ctx, "ValidateScene", [this, req, resp] { return validate(*req, resp); });
}

grpc::ServerUnaryReactor* FrontendServiceImpl::BuildScene(grpc::CallbackServerContext* ctx, const v1::BuildSceneRequest* req,
                                                          v1::BuildSceneResponse* resp) {
  return onPool(ctx, "BuildScene", [this, req, resp] { return build(*req, resp); });
}

}  // namespace pflow::frontend
