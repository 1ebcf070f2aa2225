// SPDX-License-Identifier: GPL-3.0-or-later
// core/blas_threads.hpp: the scoped BLAS thread count and what the process runs.
#include "core/blas_threads.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace rbc {
namespace {

/// Steps 0, 1, 2, ... handed between threads: wait_for(k) blocks until step k is reached.
struct Steps {
  std::mutex m;
  std::condition_variable cv;
  int step = 0;
  void advance() {
    {
      const std::lock_guard<std::mutex> lock(m);
      ++step;
    }
    cv.notify_all();
  }
  void wait_for(int k) {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return step >= k; });
  }
};

// Two guards alive at once in two threads (Python threads, the calibration's forward runs),
// ended in the order they started (A starts, B starts, A ends, B ends). OpenBLAS's OpenMP build
// (the one .ci/bootstrap.sh installs) sizes each call's team from the calling thread's OpenMP
// thread count, which openblas_set_num_threads sets for the caller only: every guard must set
// its own thread's count and restore it, A's end must leave B's, and OpenMP regions stay
// inactive in B until B's guard ends. (A guard that set the count only for the first of
// several threads left the second factorising on OpenBLAS's threaded path inside an inactive
// region: SparseCholesky.ConcurrentAnalysesGiveTheSerialSolutionBitForBit then hung.)
TEST(ScopedBlasThreads, OverlappingGuardsInTwoThreadsEachHoldTheirOwnThread) {
  if (blas_info().config.find("USE_OPENMP") == std::string::npos)
    GTEST_SKIP() << "not OpenBLAS's OpenMP build: " << blas_info().config;
  const int levels_before = omp_get_max_active_levels();
  const int threads_before = omp_get_max_threads();
  Steps steps;
  int b_threads_after_a = -1, b_levels_after_a = -1, b_threads_after = -1, b_levels_after = -1;
  std::thread a([&] {
    {
      const ScopedBlasThreads guard(1);
      steps.advance();  // 1: A holds
      steps.wait_for(2);
    }
    steps.advance();  // 3: A ended
  });
  std::thread b([&] {
    omp_set_num_threads(2);
    const int levels = omp_get_max_active_levels();
    steps.wait_for(1);
    {
      const ScopedBlasThreads guard(1);
      steps.advance();  // 2: B holds
      steps.wait_for(3);
      b_threads_after_a = omp_get_max_threads();
      b_levels_after_a = omp_get_max_active_levels();
    }
    b_threads_after = omp_get_max_threads();
    b_levels_after = omp_get_max_active_levels() == levels ? 1 : 0;
  });
  a.join();
  b.join();
  EXPECT_EQ(b_threads_after_a, 1);  // B's guard still holds after A's ended
  EXPECT_EQ(b_levels_after_a, 0);
  EXPECT_EQ(b_threads_after, 2);  // and gives B its own settings back
  EXPECT_EQ(b_levels_after, 1);
  EXPECT_EQ(omp_get_max_threads(), threads_before);  // the main thread's are untouched
  EXPECT_EQ(omp_get_max_active_levels(), levels_before);
}

// OpenBLAS's own count is one per process: guards overlapping in two threads, ended in either
// order, give back the count from before the first of them, and it stays at the guards' 1 while
// any of them holds. (Each guard restoring the count it saw at its start left 1 for good when B
// started while A held it: numpy in the same Python process then ran on one thread.)
TEST(ScopedBlasThreads, OverlappingGuardsGiveBackTheProcessWideCount) {
  if (!&openblas_get_num_threads || !&openblas_set_num_threads)
    GTEST_SKIP() << "no OpenBLAS entry points";
  const int count_before = openblas_get_num_threads();
  const int omp_before = omp_get_max_threads();
  openblas_set_num_threads(3);  // not the guards' 1, nor a likely default
  omp_set_num_threads(omp_before);
  for (const bool a_ends_first : {true, false}) {
    SCOPED_TRACE(a_ends_first ? "A, B, A ends, B ends" : "A, B, B ends, A ends");
    Steps steps;
    int count_between = -1;
    // Steps: 1 A holds, 2 B holds, 3 the first ends (A or B), 4 the count read, 5 the second ends.
    const auto run = [&](bool first, bool starts_first) {
      if (!starts_first) steps.wait_for(1);
      {
        const ScopedBlasThreads guard(1);
        steps.advance();  // 1 or 2
        steps.wait_for(first ? 2 : 4);
      }
      steps.advance();  // 3 (the first to end) or 5
    };
    std::thread a([&] { run(a_ends_first, true); });
    std::thread b([&] { run(!a_ends_first, false); });
    steps.wait_for(3);
    count_between = openblas_get_num_threads();  // the second guard still holds
    steps.advance();                             // 4
    a.join();
    b.join();
    EXPECT_EQ(count_between, 1);
    EXPECT_EQ(openblas_get_num_threads(), 3);
  }
  openblas_set_num_threads(count_before);
  omp_set_num_threads(omp_before);
}

// A guard nested in another in one thread: the inner one's end leaves the outer's settings.
TEST(ScopedBlasThreads, NestedGuardsRestoreOnlyAtTheOutermost) {
  const int levels_before = omp_get_max_active_levels();
  {
    const ScopedBlasThreads outer(1);
    { const ScopedBlasThreads inner(1); }
    EXPECT_EQ(omp_get_max_active_levels(), 0);
    if (&openblas_get_num_threads) {
      EXPECT_EQ(openblas_get_num_threads(), 1);
    }
  }
  EXPECT_EQ(omp_get_max_active_levels(), levels_before);
  { const ScopedBlasThreads none(0); }  // threads <= 0: nothing changes
  EXPECT_EQ(omp_get_max_active_levels(), levels_before);
}

TEST(BlasInfo, NamesOpenBlasWhereItIsLinked) {
  const BlasInfo b = blas_info();
  if (!&openblas_get_corename) {
    EXPECT_EQ(b.library, "unknown");
    return;
  }
  EXPECT_EQ(b.library, "OpenBLAS");
  EXPECT_FALSE(b.core.empty());
  EXPECT_NE(b.config.find("OpenBLAS"), std::string::npos);
  EXPECT_GE(b.threads, 1);
}

}  // namespace
}  // namespace rbc
