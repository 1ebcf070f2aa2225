// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Scoped thread count of OpenBLAS, whose pthreads build (Debian's default libopenblas0)
// ignores OpenMP's thread count: CHOLMOD's supernodal factorisation issues thousands of
// small BLAS calls, and on the small problems of parameter sweeps each call's thread
// wake-ups cost more than its arithmetic (measured, note_speed.md: at 1,000 continuum
// elements a quarter of the CPU time was futex wake-ups). One BLAS thread also makes the
// factorisation's rounding independent of the machine's core count. The OpenBLAS entry
// points are weak references, so any BLAS works (then this is a no-op). The OpenMP
// build of OpenBLAS (Debian's openblas-openmp) sets the caller's OpenMP thread count in
// openblas_set_num_threads, so the guard restores that count too: the caller's element
// loops keep their threads.
#include <omp.h>

#include <mutex>
#include <string>

// OpenBLAS's own entry points, as weak references: null where the process runs another BLAS.
// Weak references resolve through the loading object's own dependencies, so they are found in
// the Python extension too, which Python loads privately (RTLD_LOCAL): a lookup by
// dlsym(RTLD_DEFAULT) sees only the global scope and found nothing there, so this guard did
// nothing in the Python package (tests/python/test_api.py checks blas_info() there).
extern "C" {
int openblas_get_num_threads() __attribute__((weak));
void openblas_set_num_threads(int) __attribute__((weak));
char* openblas_get_corename() __attribute__((weak));
char* openblas_get_config() __attribute__((weak));
}

namespace rbc {

/// The BLAS this process runs, for run records and benchmark output: which OpenBLAS kernel is
/// in use changes the factorisation's speed by 14-25 % on the project's machines (README,
/// "Which OpenBLAS kernel") and its rounding. Found as ScopedBlasThreads finds OpenBLAS.
struct BlasInfo {
  std::string library;  ///< "OpenBLAS", or "unknown" for a BLAS without OpenBLAS's entry points
  /// OpenBLAS's kernel (openblas_get_corename, e.g. "haswell", "skylakex"): the CPU's, or the
  /// one OPENBLAS_CORETYPE names, chosen when the library was loaded. Empty if unknown.
  std::string core;
  std::string config;  ///< openblas_get_config (version and build options); empty if unknown
  int threads = 0;     ///< openblas_get_num_threads now; 0 if unknown
};
/// Defined below ScopedBlasThreads.
BlasInfo blas_info();

namespace detail {
/// OpenBLAS's own thread count (blas_cpu_number, what openblas_get_num_threads returns) is one
/// per process, unlike the OpenMP settings the guards also change. Guards alive at once in
/// several threads share it: the first to start saves it, the last to end restores it. Each
/// guard restoring what it saw (the earlier code) let a guard that started while another held
/// the count restore that guard's 1 for good, and every later BLAS caller of the process (numpy,
/// in the Python package) stayed on one thread (tests/core/test_blas_threads.cpp). This is
/// process-wide state because the count it mirrors is.
struct BlasCountHolders {
  std::mutex mutex;
  int holders = 0;  ///< guards alive that set the count
  int saved = 0;    ///< the count before the first of them
};
inline BlasCountHolders& blas_count_holders() {
  static BlasCountHolders h;
  return h;
}
/// Sets OpenBLAS's count to `threads` as one more holder; false without OpenBLAS. In OpenBLAS's
/// OpenMP build this also sets the calling thread's OpenMP count.
inline bool hold_blas_count(int threads) {
  if (!&openblas_get_num_threads || !&openblas_set_num_threads) return false;
  BlasCountHolders& h = blas_count_holders();
  const std::lock_guard<std::mutex> lock(h.mutex);
  if (h.holders++ == 0) h.saved = openblas_get_num_threads();
  openblas_set_num_threads(threads);
  return true;
}
/// Ends a hold_blas_count; the last holder restores the count from before the first.
inline void release_blas_count() {
  BlasCountHolders& h = blas_count_holders();
  const std::lock_guard<std::mutex> lock(h.mutex);
  if (--h.holders == 0 && h.saved > 0) openblas_set_num_threads(h.saved);
}
}  // namespace detail

/// Each guard sets and restores the calling thread's OpenMP settings, which is what guards alive
/// at once in several threads need: OpenBLAS's OpenMP build sizes each call's team from the
/// caller's OpenMP thread count (set by openblas_set_num_threads for the caller), and libgomp
/// keeps max-active-levels per thread. OpenBLAS's process-wide count is restored by the last
/// guard to end (detail::BlasCountHolders; tests/core/test_blas_threads.cpp). While several hold
/// it, it is the last one set: guards alive at once should ask for the same count (every caller
/// in the project asks for 1).
class ScopedBlasThreads {
 public:
  /// threads <= 0: leave the thread counts alone.
  explicit ScopedBlasThreads(int threads) {
    if (threads <= 0) return;
    active_ = true;
    saved_omp_ = omp_get_max_threads();
    saved_levels_ = omp_get_max_active_levels();
    // CHOLMOD's supernodal code opens its own regions with num_threads(4) (SuiteSparse 5's
    // CHOLMOD_OMP_NUM_THREADS); with one thread requested, no region may be active.
    holds_blas_ = detail::hold_blas_count(threads);  // first: it may throw (the mutex)
    if (threads == 1) omp_set_max_active_levels(0);
  }
  ~ScopedBlasThreads() {
    if (!active_) return;
    if (holds_blas_) detail::release_blas_count();
    omp_set_num_threads(saved_omp_);
    omp_set_max_active_levels(saved_levels_);
  }
  ScopedBlasThreads(const ScopedBlasThreads&) = delete;
  ScopedBlasThreads& operator=(const ScopedBlasThreads&) = delete;

 private:
  bool active_ = false, holds_blas_ = false;
  int saved_omp_ = 1, saved_levels_ = 1;
};

/// OpenBLAS's process-wide count only, held as ScopedBlasThreads holds it; the calling thread's
/// OpenMP count is kept. For a caller that runs its own parallel region around many BLAS-calling
/// tasks (calibrate's run_inference, whose forward runs each take one core): it used to set the
/// count to 1 for the rest of the process, so numpy ran on one thread after `rbc.infer` in
/// Python (tests/calibrate/test_recovery.cpp).
class ScopedProcessBlasThreads {
 public:
  explicit ScopedProcessBlasThreads(int threads) {
    if (threads <= 0) return;
    const int omp_threads = omp_get_max_threads();
    holds_blas_ = detail::hold_blas_count(threads);
    omp_set_num_threads(omp_threads);
  }
  ~ScopedProcessBlasThreads() {
    if (!holds_blas_) return;
    const int omp_threads = omp_get_max_threads();
    detail::release_blas_count();
    omp_set_num_threads(omp_threads);
  }
  ScopedProcessBlasThreads(const ScopedProcessBlasThreads&) = delete;
  ScopedProcessBlasThreads& operator=(const ScopedProcessBlasThreads&) = delete;

 private:
  bool holds_blas_ = false;
};

inline BlasInfo blas_info() {
  BlasInfo b;
  b.library = &openblas_get_corename ? "OpenBLAS" : "unknown";
  if (const char* core = &openblas_get_corename ? openblas_get_corename() : nullptr) b.core = core;
  if (const char* config = &openblas_get_config ? openblas_get_config() : nullptr)
    b.config = config;
  if (&openblas_get_num_threads) b.threads = openblas_get_num_threads();
  return b;
}

}  // namespace rbc
