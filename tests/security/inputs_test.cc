// Confined inputs and bounded work in the scene loader (label `security`): every path trick of issue 19 against a
// scene loaded as the frontend service loads it (confined to its upload), the same tricks a local `pflow run` must
// survive (no hang on a FIFO, no endless read of /dev/zero, no huge file), and YAML bombs. Then the real frontend
// service over TLS: a submitted scene naming a file outside its upload gets the loader's error, not the file.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "compute/dem/TimeStep.h"
#include "frontend/SceneLoader.h"
#include "frontend/SceneSummary.h"
#include "frontend/service/FrontendService.h"
#include "pflow/frontend/v1/frontend_service.grpc.pb.h"
#include "tests/agent/AgentTestUtil.h"
#include "tests/security/SecurityFixture.h"

namespace pflow::security_test {
namespace {

namespace fs = std::filesystem;
using frontend::LoadOptions;

const std::string kMat =
    "materials:\n"
    "  - {name: glass, youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500, restitution: 0.5, friction: 0.5}\n"
    "simulation: {duration: 0.1}\n";

std::string csvScene(const std::string& file) { return kMat + "particles:\n  - {file: '" + file + "'}\n"; }
std::string meshScene(const std::string& file) { return kMat + "geometry:\n  - {name: m, mesh: {file: '" + file + "'}}\n"; }

class Inputs : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ofstream(m_dir / "ok.csv") << "x,y,z,radius\n0,0,0,0.001\n";
    fs::create_directory(m_dir / "upload");
    std::ofstream(m_dir / "upload/ok.csv") << "x,y,z,radius\n0,0,0,0.001\n";
    std::ofstream(m_dir / "secret.csv") << "x,y,z,radius\nSECRET,0,0,0.001\n";
  }
  Result<frontend::LoadedScene> load(const std::string& yaml, bool confined, std::uintmax_t maxFileBytes = std::uintmax_t(1) << 31) {
    LoadOptions o;
    o.baseDir = confined ? m_dir / "upload" : m_dir.path();
    o.confineFiles = confined;
    o.maxFileBytes = maxFileBytes;
    return frontend::loadSceneFromString(yaml, "scene.yaml", o);
  }
  static void expectRefused(const Result<frontend::LoadedScene>& r, const std::string& says) {
    ASSERT_FALSE(r);
    EXPECT_NE(r.status().message().find(says), std::string::npos) << r.status().message();
    EXPECT_EQ(r.status().message().find("SECRET"), std::string::npos) << "leaks the file: " << r.status().message();
    EXPECT_EQ(r.status().message().find("root:"), std::string::npos) << "leaks /etc/passwd: " << r.status().message();
  }
  agent::testing::TempDir m_dir;
};

TEST_F(Inputs, AnUploadReadsItsOwnFiles) { EXPECT_TRUE(load(csvScene("ok.csv"), true)); }

TEST_F(Inputs, AbsolutePathsAreRefusedInAnUpload) {
  expectRefused(load(csvScene("/etc/passwd"), true), "absolute path is not allowed");
  expectRefused(load(meshScene(m_dir / "secret.csv"), true), "absolute path is not allowed");
}

TEST_F(Inputs, DotDotIsRefusedInAnUpload) {
  expectRefused(load(csvScene("../secret.csv"), true), "'..' is not allowed");
  expectRefused(load(csvScene("a/../../secret.csv"), true), "'..' is not allowed");
}

TEST_F(Inputs, LinksOutOfTheUploadAreRefused) {
  fs::create_symlink(m_dir / "secret.csv", m_dir / "upload/link.csv");
  fs::create_symlink("/etc", m_dir / "upload/etc");
  expectRefused(load(csvScene("link.csv"), true), "link out of the scene's folder");
  expectRefused(load(csvScene("etc/passwd"), true), "link out of the scene's folder");
}

TEST_F(Inputs, AFifoIsRefusedNotWaitedOn) {
  ASSERT_EQ(::mkfifo((m_dir / "upload/pipe.csv").c_str(), 0600), 0);
  const auto t0 = std::chrono::steady_clock::now();
  expectRefused(load(csvScene("pipe.csv"), true), "not a regular file");
  ASSERT_EQ(::mkfifo((m_dir / "pipe.stl").c_str(), 0600), 0);
  expectRefused(load(meshScene("pipe.stl"), false), "not a regular file");  // a local run too
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
}

TEST_F(Inputs, DevicesAreRefusedNotReadForever) {
  expectRefused(load(csvScene("/dev/zero"), false), "not a regular file");
  expectRefused(load(meshScene("/dev/urandom"), false), "not a regular file");
}

TEST_F(Inputs, HugeFilesAreRefusedBeforeReading) {
  {
    std::ofstream big(m_dir / "upload/big.csv");
  }
  fs::resize_file(m_dir / "upload/big.csv", (std::uintmax_t(2) << 30) + 1);  // 2 GiB and a byte, sparse
  const auto t0 = std::chrono::steady_clock::now();
  expectRefused(load(csvScene("big.csv"), true, std::uintmax_t(64) << 20), "the limit is 67108864");
  expectRefused(load(csvScene("upload/big.csv"), false), "the limit is 2147483648");  // the local default
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
}

// `levels` levels of ten aliases each, the first ten numbers: 10^levels values when the aliases are followed.
std::string aliasesOfAliases(int levels) {
  std::string yaml = "a0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\n";
  for (int i = 1; i < levels; ++i) {
    yaml += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [";
    for (int k = 0; k < 10; ++k) yaml += std::string(k ? ", " : "") + "*a" + std::to_string(i - 1);
    yaml += "]\n";
  }
  return yaml;
}

TEST(YamlBombs, AliasesOfAliasesAreRefusedQuickly) {
  // 10^30 values when followed. The expansion is counted once per anchored node (a millisecond here); it used to be
  // walked until 2e7 values, 1.1 s on 2 cores and 6.5 s on a loaded CI machine.
  const std::string yaml = aliasesOfAliases(30);
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = frontend::loadSceneFromString(yaml, "bomb.yaml");
  ASSERT_FALSE(r);
  EXPECT_NE(r.status().message().find("aliases"), std::string::npos) << r.status().message();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(1));
}

TEST(YamlBombs, AliasesBelowTheLimitAreFollowed) {
  // 10^4 values, far below the limit: the scene is refused for its content (the unknown key a0), not its aliases.
  const auto r = frontend::loadSceneFromString(aliasesOfAliases(4), "tame.yaml");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().message().find("expands"), std::string::npos) << r.status().message();
  EXPECT_NE(r.status().message().find("a0"), std::string::npos) << r.status().message();
}

TEST(YamlBombs, DeepNestingIsRefusedBeforeParsing) {
  const std::string yaml = "a: " + std::string(100000, '[') + std::string(100000, ']') + "\n";
  const auto r = frontend::loadSceneFromString(yaml, "deep.yaml");
  ASSERT_FALSE(r);
  EXPECT_NE(r.status().message().find("nested deeper than 64"), std::string::npos) << r.status().message();
}

TEST(YamlBombs, OversizedDocumentsAreRefusedBeforeParsing) {
  LoadOptions o;
  o.maxSceneBytes = 1 << 20;
  const std::string yaml = kMat + "# " + std::string(2 << 20, 'x') + "\n";
  const auto r = frontend::loadSceneFromString(yaml, "big.yaml", o);
  ASSERT_FALSE(r);
  EXPECT_NE(r.status().message().find("the limit is 1048576"), std::string::npos) << r.status().message();
}

TEST(FieldOverflows, DurationsThatOverflowTheStepCountAreErrors) {
  // 1e18 s at a microsecond step would overflow the step count to a run of zero steps that "succeeds". The time step
  // is known once the scene is loaded: what validate, the frontend's build and `pflow run` do next refuses it.
  std::string yaml = kMat + "particles:\n  - list: [{position: [0, 0, 0], radius: 0.001}]\n";
  yaml.replace(yaml.find("duration: 0.1"), 13, "duration: 1e18");
  const auto scene = frontend::loadSceneFromString(yaml, "dem.yaml");
  ASSERT_TRUE(scene) << scene.status().message();
  const auto summary = frontend::summarize(scene.value());
  ASSERT_FALSE(summary);
  EXPECT_NE(summary.status().message().find("simulation.duration: 1e+18 s at dt"), std::string::npos) << summary.status().message();
  EXPECT_NE(summary.status().message().find("a run may take at most 1e+12"), std::string::npos) << summary.status().message();
  auto ts = compute::chooseTimeStep(scene->config);  // the DEM run's own first step
  EXPECT_FALSE(ts);
}

TEST_F(TlsProcess, TheFrontendReadsOnlyTheUpload) {
  agent::testing::TempDir dir;
  frontend::ModelStore store(dir.path());
  frontend::FrontendServiceImpl service(store);
  auto server = rpc::ServerRunner::start("127.0.0.1:0", {&service}, as("frontend"));
  ASSERT_TRUE(server);
  auto stub = frontend::v1::FrontendService::NewStub(rpc::makeChannel(server.value()->address(), as("manager")));
  for (const std::string& path : {std::string("/etc/passwd"), std::string("../../../../etc/passwd")}) {
    frontend::v1::ValidateSceneRequest req;
    req.set_scene_yaml(csvScene(path));
    req.set_scene_name("scene.yaml");
    frontend::v1::ValidateSceneResponse resp;
    ASSERT_TRUE(stub->ValidateScene(call().get(), req, &resp).ok());
    EXPECT_FALSE(resp.valid());
    std::string all;
    for (const auto& e : resp.errors()) all += e.message() + "\n";
    EXPECT_NE(all.find("not allowed"), std::string::npos) << all;
    EXPECT_EQ(all.find("root:"), std::string::npos) << all;
  }
  // An attachment named as one of the model's own files would replace the scene that was checked.
  frontend::v1::BuildSceneRequest build;
  build.set_scene_yaml(csvScene("ok.csv"));
  build.set_scene_name("scene.yaml");
  auto* ok = build.add_files();
  ok->set_path("ok.csv");
  ok->set_content("x,y,z,radius\n0,0,0,0.001\n");
  auto* evil = build.add_files();
  evil->set_path("./scene.yaml");
  evil->set_content(csvScene("/etc/passwd"));
  frontend::v1::BuildSceneResponse built;
  const auto s = stub->BuildScene(call().get(), build, &built);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_NE(s.error_message().find("the model's own"), std::string::npos) << s.error_message();
  server.value()->shutdown(1);
}

}  // namespace
}  // namespace pflow::security_test
