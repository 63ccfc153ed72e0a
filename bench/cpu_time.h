// Process CPU time for the benchmark programs that time single calls (all threads of the process).
#pragma once

#include <ctime>

namespace orpe::bench {

/// Seconds of CPU the process has used so far (CLOCK_PROCESS_CPUTIME_ID).
inline double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

}  // namespace orpe::bench
