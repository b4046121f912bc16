// Test binary entry: Kokkos lives for the whole Catch2 session.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>
#include <Kokkos_Core.hpp>
#include <cstdlib>

int main(int argc, char* argv[]) {
  // Unit-test thread binding unless the caller chose one. Without it Kokkos prints a
  // four-line warning on stdout, and the test discovery (which reads the binary's list of
  // test names from stdout) took those lines for four tests that matched nothing.
  setenv("OMP_PROC_BIND", "false", 0);
  Kokkos::initialize(argc, argv);
  int result = Catch::Session().run(argc, argv);
  Kokkos::finalize();
  return result;
}
