// The MPI ranks of a `mpirun -n K tamp calibrate|diagnose ...` (drivers/loop/ForwardRuns.hpp:
// the ranks share a batch of forward runs and every rank gets every result). Without MPI
// (not built with it, or not launched by mpirun) there is one rank and nothing here talks.
#pragma once
#include <string>
#include <vector>

namespace tamp {

struct Ranks {
  int rank = 0;
  int size = 1;
};

// The ranks of this process (size 1 until ranks_init, or without MPI).
const Ranks& ranks();
// Starts MPI if this build has it and the process was launched by an MPI launcher (its
// environment says so); otherwise leaves one rank. Returns ranks().
const Ranks& ranks_init(int* argc, char*** argv);
void ranks_finalize();
// Every rank's `mine`, in rank order, on every rank (one rank: {mine}).
std::vector<std::string> allgather(const std::string& mine);
// Whether this build can run under MPI.
bool built_with_mpi();

}  // namespace tamp
