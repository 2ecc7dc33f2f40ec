// For the performance gate (bench/perf_gate) only: valgrind 3.19 (Debian 12) cannot execute
// RDTSCP on a CPU that does not announce it (virtual machines often hide it), and Highway
// (libhwy, loaded through OpenImageIO -> libjxl) executes it in a static initialiser, measuring
// its timer's resolution: every Sawyer process then dies of SIGILL under valgrind before main.
// Preloaded into the process under valgrind, this takes the place of that one function (its
// result only tunes Highway's own benchmarking helpers, which Sawyer never calls). Not linked
// into anything Sawyer ships.
#include <cstdint>

namespace hwy::platform {

uint64_t TimerResolution() { return 1; }

}  // namespace hwy::platform
