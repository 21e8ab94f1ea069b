// What the MPI benchmark programs (pflow-bench-mpi, pflow-sph-bench) share: each step-loop phase's seconds over the
// ranks of MPI_COMM_WORLD.
#pragma once
#include <mpi.h>

#include <nlohmann/json.hpp>
#include <vector>

#include "compute/sim/PhaseTimers.h"

namespace pflow::bench {

// Each phase's seconds summed over the ranks and the largest of them, on every rank (collective).
struct PhaseSpread {
  std::vector<double> sum, max;  // by compute::Phase
  // {"forces": seconds, ...} of every phase: the mean over `ranks` ranks, or the largest.
  nlohmann::json mean(int ranks) const { return named(sum, 1.0 / ranks); }
  nlohmann::json largest() const { return named(max, 1.0); }

 private:
  static nlohmann::json named(const std::vector<double>& v, double scale) {
    nlohmann::json j = nlohmann::json::object();
    for (std::size_t p = 0; p < v.size(); ++p) j[compute::kPhaseNames[p]] = v[p] * scale;
    return j;
  }
};

inline PhaseSpread phaseSpread(const compute::PhaseTimers& timers) {
  const int np = int(compute::Phase::kCount);
  PhaseSpread s;
  s.sum.resize(std::size_t(np));
  for (int p = 0; p < np; ++p) s.sum[std::size_t(p)] = timers.seconds(compute::Phase(p));
  s.max = s.sum;
  MPI_Allreduce(MPI_IN_PLACE, s.sum.data(), np, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, s.max.data(), np, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return s;
}

}  // namespace pflow::bench
