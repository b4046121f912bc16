#include "drivers/loop/Ranks.hpp"

#include <cstdlib>
#include <stdexcept>

#ifdef TAMP_HAVE_MPI
#define OMPI_SKIP_MPICXX 1  // the C API only (the C++ bindings need their own library)
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace tamp {
namespace {
Ranks g_ranks;
bool g_started = false;
}  // namespace

const Ranks& ranks() { return g_ranks; }

bool built_with_mpi() {
#ifdef TAMP_HAVE_MPI
  return true;
#else
  return false;
#endif
}

const Ranks& ranks_init(int* argc, char*** argv) {
#ifdef TAMP_HAVE_MPI
  // Open MPI, MPICH / Hydra and PMIx launchers set one of these; a plain start does not, so
  // that a single `tamp diagnose` (and every forward-run child) never starts MPI.
  const bool launched = std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK");
  if (launched && !g_started) {
    // FUNNELED: the fits of a diagnosis step run in host threads of their own
    // (ForwardRuns::side_by_side), but only the main thread calls MPI
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    if (provided < MPI_THREAD_FUNNELED)
      throw std::runtime_error("MPI: this MPI library does not provide MPI_THREAD_FUNNELED (the diagnosis needs it)");
    g_started = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &g_ranks.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_ranks.size);
  }
#else
  (void)argc;
  (void)argv;
#endif
  return g_ranks;
}

void ranks_finalize() {
#ifdef TAMP_HAVE_MPI
  if (g_started) MPI_Finalize();
  g_started = false;
#endif
}

std::vector<std::string> allgather(const std::string& mine) {
  if (g_ranks.size == 1) return {mine};
#ifdef TAMP_HAVE_MPI
  const int n = g_ranks.size;
  int len = static_cast<int>(mine.size());
  std::vector<int> lens(n), offsets(n, 0);
  MPI_Allgather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, MPI_COMM_WORLD);
  for (int r = 1; r < n; ++r) offsets[r] = offsets[r - 1] + lens[r - 1];
  std::string all(static_cast<size_t>(offsets[n - 1] + lens[n - 1]), '\0');
  MPI_Allgatherv(mine.data(), len, MPI_CHAR, all.data(), lens.data(), offsets.data(), MPI_CHAR, MPI_COMM_WORLD);
  std::vector<std::string> out(n);
  for (int r = 0; r < n; ++r) out[r] = all.substr(static_cast<size_t>(offsets[r]), static_cast<size_t>(lens[r]));
  return out;
#else
  throw std::logic_error("allgather: more than one rank without MPI");
#endif
}

}  // namespace tamp
