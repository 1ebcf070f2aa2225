// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// CPU clocks for the statistics and benchmarks that quote CPU time next to wall time (the
// machines are shared, so CPU time is the figure that compares run to run).
#include <ctime>

namespace rbc {

/// Process CPU time (s, all threads) since an arbitrary origin.
inline double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// CPU time (s) of the calling thread since an arbitrary origin.
inline double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace rbc
