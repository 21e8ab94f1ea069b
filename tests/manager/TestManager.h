// A manager in this process for service tests (security, viewer, fuzz): the domain over fake agent and frontend
// clients (Fakes.h), users in SQLite, and ManagerService with NodeRegistry served on loopback, the way pflow-manager
// wires them (a pool for user calls, one for nodes, optionally a build queue). What the tests vary is in Options.
#pragma once
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "common/rpc/Rpc.h"
#include "manager/ManagerService.h"
#include "manager/Users.h"
#include "tests/manager/Fakes.h"

namespace pflow::manager::testing {

struct TestManager {
  struct Options {
    std::string db = ":memory:";       // the job and user tables (one file may hold both)
    ManagerOptions manager;
    const Clock* clock = nullptr;      // null: a FakeClock at t = 1000 s
    int userThreads = 2, nodeThreads = 2;
    int buildThreads = 0;              // 0: SubmitJob builds before it answers; else a build queue of this many
    int maxPendingBuilds = 64;
    bool verifyNodes = false;          // NodeRegistry checks node certificates (the server runs TLS)
    rpc::Transport transport = rpc::Transport::plaintext();
  };

  explicit TestManager(Options o) : options(std::move(o)) {
    jobStore = JobStore::open(options.db).value();
    users = UserStore::open(options.db).value();
    manager = Manager::create(options.manager, options.clock ? *options.clock : fakeClock, *jobStore, agents, frontend).value();
    userPool = std::make_unique<TaskPool>(options.userThreads);
    nodePool = std::make_unique<TaskPool>(options.nodeThreads);
    if (options.buildThreads > 0) builds = std::make_unique<TaskPool>(options.buildThreads);
    service = std::make_unique<ManagerServiceImpl>(*manager, *users, *userPool, builds.get(), options.maxPendingBuilds);
    registry = std::make_unique<NodeRegistryImpl>(*manager, *nodePool, options.verifyNodes);
    server = rpc::ServerRunner::start("127.0.0.1:0", {service.get(), registry.get()}, options.transport).value();
  }
  ~TestManager() {
    server->shutdown(1);
    builds.reset();  // the build tasks hold the Manager: done before it goes
    userPool.reset();
    nodePool.reset();
  }
  std::string address() const { return server->address(); }
  // A new user's token.
  std::string addUser(const std::string& name, bool admin = false) { return users->add(name, admin, 0).value(); }
  // A job of `owner`'s, submitted through the domain (built at once, placed when a device is free).
  std::string submitAs(const std::string& owner, unsigned long long particles = 10) {
    SubmitRequest r = submitRequest(particles, true);
    r.owner = owner;
    return manager->submit(r).value().id;
  }

  Options options;
  FakeClock fakeClock{1000};
  FakeAgentClient agents;
  FakeFrontendClient frontend;
  std::unique_ptr<JobStore> jobStore;
  std::unique_ptr<UserStore> users;
  std::unique_ptr<Manager> manager;
  std::unique_ptr<TaskPool> userPool, nodePool, builds;
  std::unique_ptr<ManagerServiceImpl> service;
  std::unique_ptr<NodeRegistryImpl> registry;
  std::unique_ptr<rpc::ServerRunner> server;
};

}  // namespace pflow::manager::testing
