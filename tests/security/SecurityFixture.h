// What the security tests share: a pflow CA with service and node certificates made once per test program by
// deploy/local/certs.sh (the script start.sh uses), a second CA nobody trusts, and client transports for each
// identity. The test program itself runs as a TLS process (the default transport is TLS), so the services it hosts
// check their callers as they do in production.
#pragma once
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "common/rpc/Rpc.h"

namespace pflow::security_test {

class Certificates {
 public:
  static Certificates& get() {
    static Certificates c;
    return c;
  }
  const std::string& dir() const { return m_dir; }
  const std::string& strangerDir() const { return m_stranger; }
  // The transport of `name` (manager, frontend, backend, node-a, node-b) from the pflow CA.
  rpc::Transport as(const std::string& name) const {
    auto t = rpc::Transport::fromDir(m_dir, name);
    EXPECT_TRUE(t) << t.status().toString();
    return t.value();
  }
  // A client with the CA only (the CLI: a user, authenticated by token).
  rpc::Transport user() const {
    auto t = rpc::Transport::caOnly(m_dir + "/ca.crt");
    EXPECT_TRUE(t) << t.status().toString();
    return t.value();
  }
  // A node certificate from another CA (that trusts nothing of ours either).
  rpc::Transport stranger() const {
    auto t = rpc::Transport::fromDir(m_stranger, "node-a");
    EXPECT_TRUE(t) << t.status().toString();
    return t.value();
  }
  bool ok() const { return m_ok; }

 private:
  Certificates() {
    namespace fs = std::filesystem;
    m_dir = (fs::temp_directory_path() / ("pflow-security-" + std::to_string(::getpid()))).string();
    m_stranger = m_dir + "-stranger";
    const std::string script = std::string(PFLOW_SOURCE_DIR) + "/deploy/local/certs.sh";
    m_ok = std::system((script + " " + m_dir + " manager frontend backend node:a node:b > /dev/null").c_str()) == 0 &&
           std::system((script + " " + m_stranger + " node:a > /dev/null").c_str()) == 0;
  }
  ~Certificates() {
    std::error_code ec;
    std::filesystem::remove_all(m_dir, ec);
    std::filesystem::remove_all(m_stranger, ec);
  }
  std::string m_dir, m_stranger;
  bool m_ok = false;
};

// Makes this process a TLS process (services verify their callers) for the test's duration.
class TlsProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(Certificates::get().ok()) << "deploy/local/certs.sh failed";
    rpc::setDefaultTransport(Certificates::get().as("manager"));
  }
  void TearDown() override {
    rpc::setDefaultTransport(rpc::Transport::plaintext());
    rpc::setCallToken("");
  }
  static rpc::Transport as(const std::string& name) { return Certificates::get().as(name); }
  static rpc::Transport user() { return Certificates::get().user(); }
};

inline std::unique_ptr<grpc::ClientContext> call(const std::string& token = "") {
  auto ctx = rpc::contextWithDeadline(10);
  rpc::addBearer(*ctx, token);
  return ctx;
}

}  // namespace pflow::security_test
