// main() of the MPI test programs (tests/mpi): GoogleTest inside MPI_Init/MPI_Finalize; the program fails on
// every rank when a test failed on any.
#include <gtest/gtest.h>
#include <mpi.h>

#include "compute/mpi/MpiDomain.h"
#include "tests/support/MpiTest.h"

namespace pflow::test {
namespace {
int g_nodeRank = 0;
}
int nodeRank() { return g_nodeRank; }
}  // namespace pflow::test

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  pflow::test::g_nodeRank = pflow::compute::nodeRanks(MPI_COMM_WORLD).rank;
  ::testing::InitGoogleTest(&argc, argv);
  int failed = RUN_ALL_TESTS() != 0;
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return failed;
}
