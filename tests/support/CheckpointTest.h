// What the checkpoint tests share (tests/fault, tests/mpi): a snapshot's arrays by particle id, and a run taken to
// its first rebuild after a step, checkpointed there, and another resumed from it.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "compute/particles/ParticleSnapshot.h"
#include "compute/sim/SimulationState.h"

namespace pflow::test {

// The array `field` of a snapshot (gathered, in a distributed run) by particle id, as bytes.
inline std::map<Gid, std::vector<std::byte>> byId(const compute::ParticleSnapshot& s, const char* field) {
  std::map<Gid, std::vector<std::byte>> out;
  const compute::SnapshotArray* a = s.find(field);
  EXPECT_NE(a, nullptr) << field;
  if (!a || !s.find("id")) return out;
  const std::size_t each = a->data.size() / std::max<std::size_t>(1, s.n);
  const Gid* id = s.find("id")->as<Gid>();
  for (std::size_t i = 0; i < s.n; ++i) out[id[i]].assign(a->data.begin() + i * each, a->data.begin() + (i + 1) * each);
  return out;
}

// Every named array of a and b, bit for bit, particle by particle.
inline void expectSameArrays(const compute::ParticleSnapshot& a, const compute::ParticleSnapshot& b, std::initializer_list<const char*> fields,
                             const char* what = "") {
  ASSERT_EQ(a.n, b.n) << what;
  for (const char* f : fields) EXPECT_TRUE(byId(a, f) == byId(b, f)) << what << ": " << f << " differs";
}

// `sim` run to step `after`, then on to the first step that ends with a rebuild (where a state may be taken), and
// its state there (collective in a distributed run). Empty, with the reason as a test failure, if a step or the state
// fails.
template <class Sim>
std::optional<compute::SimulationState> checkpointAfter(Sim& sim, std::int64_t after) {
  if (Status s = sim.runSteps(after - sim.stepCount()); !s.isOk()) {
    ADD_FAILURE() << s.message();
    return std::nullopt;
  }
  while (!sim.justRebuilt())
    if (Status s = sim.runSteps(1); !s.isOk()) {
      ADD_FAILURE() << s.message();
      return std::nullopt;
    }
  auto state = sim.state();
  if (!state.isOk()) {
    ADD_FAILURE() << state.status().message();
    return std::nullopt;
  }
  return std::move(state).value();
}

// `sim` resumed from `state` and run to step `to`; false (with the reason as a test failure) if either fails. A
// distributed run's ranks other than 0 may pass an empty state: resume() takes rank 0's.
template <class Sim>
bool resumeTo(Sim& sim, const compute::SimulationState& state, std::int64_t to) {
  if (Status s = sim.resume(state); !s.isOk()) {
    ADD_FAILURE() << "resume: " << s.message();
    return false;
  }
  if (state.step > 0) {  // (a distributed resume's other ranks pass an empty state)
    EXPECT_EQ(sim.stepCount(), state.step);
  }
  if (Status s = sim.runSteps(to - sim.stepCount()); !s.isOk()) {
    ADD_FAILURE() << s.message();
    return false;
  }
  return true;
}

}  // namespace pflow::test
