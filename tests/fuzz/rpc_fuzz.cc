// Structured random messages for every RPC of pflow's five services (issue 19): the real servers run in this process
// on loopback (manager and node registry, frontend, back-end, agent), and for SECONDS seconds random requests, built
// field by field through protobuf reflection from values that break things (extremes, NaN, binary, path tricks, huge
// strings, scene snippets), go to a random RPC, with a valid or a forged token. Pass: no crash, every call answered
// within its deadline plus a margin (no hang), every server stops cleanly. Plaintext (--insecure's loopback mode):
// the handlers are under test here, tests/security the transport. Seeded (argument 2) so a failure repeats.
//   rpc_fuzz [SECONDS] [SEED]
#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <google/protobuf/reflection.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <random>

#include "backend/SnapshotService.h"
#include "common/rpc/Rpc.h"
#include "manager/GrpcFrontendClient.h"
#include "frontend/service/FrontendService.h"
#include "manager/ManagerService.h"
#include "manager/Users.h"
#include "manager/agent/AgentService.h"
#include "pflow/agent/v1/agent_service.grpc.pb.h"
#include "pflow/backend/v1/snapshot_service.grpc.pb.h"
#include "pflow/frontend/v1/frontend_service.grpc.pb.h"
#include "pflow/manager/v1/manager_service.grpc.pb.h"
#include "pflow/manager/v1/node_registry.grpc.pb.h"
#include "tests/manager/Fakes.h"

namespace {

using namespace pflow;
namespace pb = google::protobuf;
namespace fs = std::filesystem;
namespace mv1 = pflow::manager::v1;
namespace av1 = pflow::agent::v1;
namespace bv1 = pflow::backend::v1;
namespace fv1 = pflow::frontend::v1;

constexpr double kDeadline = 3;  // per call
constexpr double kHang = 10;     // a call not answered by then is a hang

class Random {
 public:
  explicit Random(std::uint64_t seed) : m_g(seed) {}
  int below(int n) { return std::uniform_int_distribution<int>(0, n - 1)(m_g); }
  bool chance(double p) { return std::uniform_real_distribution<double>(0, 1)(m_g) < p; }

  std::string text() {
    static const char* pieces[] = {"", "job-000001", "job-000002", "a", "node-a", "../../../etc/passwd", "/etc/passwd", "/dev/zero",
                                   "scene.yaml", "mesh.stl", "simulation: {duration: 0.01}\nparticles:\n  - list: [{position: [0, 0, 0], radius: 0.001}]\n",
                                   "a: &a [1, *a]", "x,y,z,radius\n0,0,0,1\n", "127.0.0.1:1", "Bearer x", "%s%s%n", "\xff\xfe\x00\x01"};
    switch (below(6)) {
      case 0: return std::string(pieces[below(int(std::size(pieces)))]);
      case 1: {  // binary
        std::string s(std::size_t(below(64)), '\0');
        for (char& c : s) c = char(below(256));
        return s;
      }
      case 2: return std::string(std::size_t(below(3) == 0 ? 100000 : 300), char('a' + below(26)));  // long
      case 3: return "job-" + std::to_string(below(20));
      default: return std::string(pieces[below(int(std::size(pieces)))]) + std::to_string(below(1000));
    }
  }
  std::int64_t integer() {
    static const std::int64_t values[] = {0, 1, -1, 2, 7, 1 << 20, std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::min(),
                                          std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::min()};
    return chance(0.7) ? values[below(int(std::size(values)))] : std::int64_t(m_g());
  }
  double real() {
    static const double values[] = {0, -0.0, 1, -1, 1e-300, 1e300, -1e300, std::numeric_limits<double>::quiet_NaN(),
                                    std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(), 0.001};
    return chance(0.7) ? values[below(int(std::size(values)))] : std::uniform_real_distribution<double>(-1e3, 1e3)(m_g);
  }

  // Sets random fields of `m` (nested messages to `depth`), through reflection: every request type, no list to keep.
  void fill(pb::Message& m, int depth = 0) {
    const pb::Descriptor* d = m.GetDescriptor();
    const pb::Reflection* r = m.GetReflection();
    for (int i = 0; i < d->field_count(); ++i) {
      const pb::FieldDescriptor* f = d->field(i);
      if (!chance(0.7)) continue;
      const int count = f->is_repeated() ? below(depth == 0 ? 6 : 3) : 1;
      for (int k = 0; k < count; ++k) set(m, r, f, depth);
    }
  }

 private:
  void set(pb::Message& m, const pb::Reflection* r, const pb::FieldDescriptor* f, int depth) {
    using F = pb::FieldDescriptor;
    const bool rep = f->is_repeated();
    switch (f->cpp_type()) {
      case F::CPPTYPE_STRING: {
        // proto3 strings must be UTF-8 (gRPC refuses others before any handler sees them): raw bytes for bytes fields,
        // control characters and multi-byte characters for strings.
        std::string v = text();
        if (f->type() == F::TYPE_STRING)
          for (char& c : v)
            if (static_cast<unsigned char>(c) >= 0x80) c = char(below(32));
        if (f->type() == F::TYPE_STRING && chance(0.1)) v += "\xc3\xa9\xe2\x82\xac";
        rep ? r->AddString(&m, f, v) : r->SetString(&m, f, v);
        break;
      }
      case F::CPPTYPE_INT32: rep ? r->AddInt32(&m, f, std::int32_t(integer())) : r->SetInt32(&m, f, std::int32_t(integer())); break;
      case F::CPPTYPE_INT64: rep ? r->AddInt64(&m, f, integer()) : r->SetInt64(&m, f, integer()); break;
      case F::CPPTYPE_UINT32: rep ? r->AddUInt32(&m, f, std::uint32_t(integer())) : r->SetUInt32(&m, f, std::uint32_t(integer())); break;
      case F::CPPTYPE_UINT64: rep ? r->AddUInt64(&m, f, std::uint64_t(integer())) : r->SetUInt64(&m, f, std::uint64_t(integer())); break;
      case F::CPPTYPE_DOUBLE: rep ? r->AddDouble(&m, f, real()) : r->SetDouble(&m, f, real()); break;
      case F::CPPTYPE_FLOAT: rep ? r->AddFloat(&m, f, float(real())) : r->SetFloat(&m, f, float(real())); break;
      case F::CPPTYPE_BOOL: rep ? r->AddBool(&m, f, chance(0.5)) : r->SetBool(&m, f, chance(0.5)); break;
      case F::CPPTYPE_ENUM: {
        const int value = chance(0.8) ? f->enum_type()->value(below(f->enum_type()->value_count()))->number() : int(integer());
        rep ? r->AddEnumValue(&m, f, value) : r->SetEnumValue(&m, f, value);
        break;
      }
      case F::CPPTYPE_MESSAGE:
        if (depth < 3) fill(rep ? *r->AddMessage(&m, f) : *r->MutableMessage(&m, f), depth + 1);
        break;
    }
  }
  std::mt19937_64 m_g;
};

// Every server of pflow in this process, on loopback.
struct Stack {
  Stack() : dir(fs::temp_directory_path() / ("pflow-rpc-fuzz-" + std::to_string(::getpid()))) {
    fs::create_directories(dir);
    jobStore = manager::JobStore::open(":memory:").value();
    users = manager::UserStore::open(":memory:").value();
    token = users->add("fuzz", true, 0).value();
    frontendStore = std::make_unique<frontend::ModelStore>((dir / "models").string());
    fs::create_directories(dir / "models");
    frontendService = std::make_unique<frontend::FrontendServiceImpl>(*frontendStore);
    frontendServer = rpc::ServerRunner::start("127.0.0.1:0", {frontendService.get()}).value();
    frontendClient = std::make_unique<manager::GrpcFrontendClient>(frontendServer->address(), kDeadline);
    manager::ManagerOptions options;
    managerDomain = manager::Manager::create(options, clock, *jobStore, agents, *frontendClient).value();
    pool = std::make_unique<TaskPool>(4);
    nodePool = std::make_unique<TaskPool>(2);
    builds = std::make_unique<TaskPool>(2);
    managerService = std::make_unique<manager::ManagerServiceImpl>(*managerDomain, *users, *pool, builds.get(), 16);
    registry = std::make_unique<manager::NodeRegistryImpl>(*managerDomain, *nodePool, false);
    managerServer = rpc::ServerRunner::start("127.0.0.1:0", {managerService.get(), registry.get()}).value();
    store = backend::SnapshotStore::open({(dir / "data").string(), 0, 8}).value();
    backendService = std::make_unique<backend::SnapshotService>(*store);
    backendServer = rpc::ServerRunner::start("127.0.0.1:0", {backendService.get()}).value();
    agent::AgentOptions ao;
    ao.node = "a";
    ao.launch.workdir = (dir / "agent").string();
    fs::create_directories(ao.launch.workdir);
    ao.launch.workerPath = "/bin/true";
    ao.launch.mpirun = "";
    theAgent = std::make_unique<agent::Agent>(ao, std::make_unique<agent::CpuProbe>(1), nullptr);
    agentService = std::make_unique<agent::AgentService>(*theAgent);
    agentServer = rpc::ServerRunner::start("127.0.0.1:0", {agentService.get()}).value();
  }
  ~Stack() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  // Stops every server; false when one does not stop within its grace.
  bool stop() {
    const auto t0 = std::chrono::steady_clock::now();
    theAgent->shutdown(2);
    for (auto* s : {agentServer.get(), backendServer.get(), managerServer.get(), frontendServer.get()}) s->shutdown(2);
    builds.reset();
    pool.reset();
    nodePool.reset();
    return std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30);
  }

  fs::path dir;
  FakeClock clock{1e9};
  manager::testing::FakeAgentClient agents;
  std::unique_ptr<manager::JobStore> jobStore;
  std::unique_ptr<manager::UserStore> users;
  std::string token;
  std::unique_ptr<frontend::ModelStore> frontendStore;
  std::unique_ptr<frontend::FrontendServiceImpl> frontendService;
  std::unique_ptr<rpc::ServerRunner> frontendServer;
  std::unique_ptr<manager::GrpcFrontendClient> frontendClient;
  std::unique_ptr<manager::Manager> managerDomain;
  std::unique_ptr<TaskPool> pool, nodePool, builds;
  std::unique_ptr<manager::ManagerServiceImpl> managerService;
  std::unique_ptr<manager::NodeRegistryImpl> registry;
  std::unique_ptr<rpc::ServerRunner> managerServer;
  std::unique_ptr<backend::SnapshotStore> store;
  std::unique_ptr<backend::SnapshotService> backendService;
  std::unique_ptr<rpc::ServerRunner> backendServer;
  std::unique_ptr<agent::Agent> theAgent;
  std::unique_ptr<agent::AgentService> agentService;
  std::unique_ptr<rpc::ServerRunner> agentServer;
};

// One RPC of a service: makes a random request and calls it.
using Call = std::function<grpc::Status(Random&, grpc::ClientContext*)>;

template <class Req, class Resp, class Stub, class Method>
Call unary(Stub* stub, Method method) {
  return [stub, method](Random& r, grpc::ClientContext* ctx) {
    Req req;
    r.fill(req);
    Resp resp;
    return (stub->*method)(ctx, req, &resp);
  };
}

template <class Req, class Msg, class Stub, class Method>
Call reading(Stub* stub, Method method) {
  return [stub, method](Random& r, grpc::ClientContext* ctx) {
    Req req;
    r.fill(req);
    auto reader = (stub->*method)(ctx, req);
    Msg msg;
    for (int i = 0; i < 3 && reader->Read(&msg); ++i) {
    }
    ctx->TryCancel();
    return reader->Finish();
  };
}

template <class Chunk, class Resp, class Stub, class Method>
Call writing(Stub* stub, Method method) {
  return [stub, method](Random& r, grpc::ClientContext* ctx) {
    Resp resp;
    auto writer = (stub->*method)(ctx, &resp);
    for (int i = r.below(4); i > 0; --i) {
      Chunk chunk;
      r.fill(chunk);
      if (!writer->Write(chunk)) break;
    }
    writer->WritesDone();
    return writer->Finish();
  };
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 60;
  const std::uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : std::random_device()();
  spdlog::set_level(spdlog::level::err);  // the services log every refusal; the fuzzer's own lines are what count
  Stack s;
  auto mstub = mv1::ManagerService::NewStub(rpc::makeChannel(s.managerServer->address()));
  auto nstub = mv1::NodeRegistry::NewStub(rpc::makeChannel(s.managerServer->address()));
  auto bstub = bv1::SnapshotService::NewStub(rpc::makeChannel(s.backendServer->address()));
  auto fstub = fv1::FrontendService::NewStub(rpc::makeChannel(s.frontendServer->address()));
  auto astub = av1::AgentService::NewStub(rpc::makeChannel(s.agentServer->address()));
  using MS = mv1::ManagerService::Stub;
  using NR = mv1::NodeRegistry::Stub;
  using BS = bv1::SnapshotService::Stub;
  using FS = fv1::FrontendService::Stub;
  using AS = av1::AgentService::Stub;
  const std::vector<std::pair<const char*, Call>> calls = {
      {"SubmitJob", unary<mv1::SubmitJobRequest, mv1::SubmitJobResponse>(mstub.get(), &MS::SubmitJob)},
      {"GetJob", unary<mv1::GetJobRequest, mv1::Job>(mstub.get(), &MS::GetJob)},
      {"ListJobs", unary<mv1::ListJobsRequest, mv1::ListJobsResponse>(mstub.get(), &MS::ListJobs)},
      {"CancelJob", unary<mv1::CancelJobRequest, mv1::Job>(mstub.get(), &MS::CancelJob)},
      {"WatchJob", reading<mv1::WatchJobRequest, mv1::JobEvent>(mstub.get(), &MS::WatchJob)},
      {"ListNodes", unary<mv1::ListNodesRequest, mv1::ListNodesResponse>(mstub.get(), &MS::ListNodes)},
      {"DeleteJob", unary<mv1::DeleteJobRequest, mv1::DeleteJobResponse>(mstub.get(), &MS::DeleteJob)},
      {"AddUser", unary<mv1::AddUserRequest, mv1::UserTokenResponse>(mstub.get(), &MS::AddUser)},
      {"RotateToken", unary<mv1::RotateTokenRequest, mv1::UserTokenResponse>(mstub.get(), &MS::RotateToken)},
      {"RemoveUser", unary<mv1::RemoveUserRequest, mv1::RemoveUserResponse>(mstub.get(), &MS::RemoveUser)},
      {"ListUsers", unary<mv1::ListUsersRequest, mv1::ListUsersResponse>(mstub.get(), &MS::ListUsers)},
      {"Heartbeat", unary<mv1::HeartbeatRequest, mv1::HeartbeatResponse>(nstub.get(), &NR::Heartbeat)},
      {"ReportProgress", unary<mv1::ReportProgressRequest, mv1::ReportProgressResponse>(nstub.get(), &NR::ReportProgress)},
      {"ReportJobExit", unary<mv1::ReportJobExitRequest, mv1::ReportJobExitResponse>(nstub.get(), &NR::ReportJobExit)},
      {"WriteSnapshot", writing<bv1::SnapshotChunk, bv1::WriteSnapshotResponse>(bstub.get(), &BS::WriteSnapshot)},
      {"ListSnapshots", unary<bv1::ListSnapshotsRequest, bv1::ListSnapshotsResponse>(bstub.get(), &BS::ListSnapshots)},
      {"ReadSnapshot", reading<bv1::ReadSnapshotRequest, bv1::SnapshotChunk>(bstub.get(), &BS::ReadSnapshot)},
      {"AppendProbes", unary<bv1::AppendProbesRequest, bv1::AppendProbesResponse>(bstub.get(), &BS::AppendProbes)},
      {"WriteCheckpoint", writing<bv1::CheckpointChunk, bv1::WriteCheckpointResponse>(bstub.get(), &BS::WriteCheckpoint)},
      {"ReadCheckpoint", reading<bv1::ReadCheckpointRequest, bv1::CheckpointChunk>(bstub.get(), &BS::ReadCheckpoint)},
      {"DeleteJobData", unary<bv1::DeleteJobDataRequest, bv1::DeleteJobDataResponse>(bstub.get(), &BS::DeleteJobData)},
      {"ValidateScene", unary<fv1::ValidateSceneRequest, fv1::ValidateSceneResponse>(fstub.get(), &FS::ValidateScene)},
      {"BuildScene", unary<fv1::BuildSceneRequest, fv1::BuildSceneResponse>(fstub.get(), &FS::BuildScene)},
      {"GetDevices", unary<av1::GetDevicesRequest, av1::GetDevicesResponse>(astub.get(), &AS::GetDevices)},
      {"StartJob", unary<av1::StartJobRequest, av1::StartJobResponse>(astub.get(), &AS::StartJob)},
      {"StopJob", unary<av1::StopJobRequest, av1::StopJobResponse>(astub.get(), &AS::StopJob)},
  };

  Random r(seed);
  std::map<std::string, std::map<int, int>> codes;  // rpc -> status code -> count
  std::map<std::pair<std::string, int>, std::string> examples;  // the first message of each unexpected code
  std::uint64_t n = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    const auto& [name, call] = calls[std::size_t(r.below(int(calls.size())))];
    auto ctx = rpc::contextWithDeadline(kDeadline);
    rpc::addBearer(*ctx, r.chance(0.6) ? s.token : r.text());
    const auto t0 = std::chrono::steady_clock::now();
    const grpc::Status st = call(r, ctx.get());
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (took > kHang) {
      std::printf("rpc_fuzz: %s took %.1f s (deadline %.0f s): a hang (seed %llu)\n", name, took, kDeadline, (unsigned long long)seed);
      return 1;
    }
    ++codes[name][st.error_code()];
    const int code = st.error_code();
    if ((code == grpc::StatusCode::INTERNAL || code == grpc::StatusCode::UNKNOWN || code == grpc::StatusCode::UNAVAILABLE) &&
        !examples.count({name, code}))
      examples[{name, code}] = st.error_message().substr(0, 200);
    ++n;
  }
  std::printf("rpc_fuzz: %llu calls in %.0f s, seed %llu; status codes per RPC:\n", (unsigned long long)n, seconds, (unsigned long long)seed);
  for (const auto& [name, byCode] : codes) {
    std::printf("  %-16s", name.c_str());
    for (const auto& [code, count] : byCode) std::printf(" %d:%d", code, count);
    std::printf("\n");
  }
  for (const auto& [key, message] : examples) std::printf("  %s %d: %s\n", key.first.c_str(), key.second, message.c_str());
  if (!s.stop()) {
    std::printf("rpc_fuzz: the servers did not stop within 30 s\n");
    return 1;
  }
  std::printf("rpc_fuzz: no crash, no hang; every server stopped\n");
  return 0;
}
