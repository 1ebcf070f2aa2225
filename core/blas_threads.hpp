#pragma once
// Scoped thread count of OpenBLAS, whose pthreads build (Debian's default libopenblas0)
// ignores OpenMP's thread count: CHOLMOD's supernodal factorisation issues thousands of
// small BLAS calls, and on the small problems of parameter sweeps each call's thread
// wake-ups cost more than its arithmetic (measured, note_speed.md: at 1,000 continuum
// elements a quarter of the CPU time was futex wake-ups). One BLAS thread also makes the
// factorisation's rounding independent of the machine's core count. The OpenBLAS entry
// points are looked up at run time, so any BLAS works (then this is a no-op). The OpenMP
// thread count of the caller (element loops) is not touched.
#include <dlfcn.h>

namespace rbc {

class ScopedBlasThreads {
 public:
  /// threads <= 0: leave the thread counts alone.
  explicit ScopedBlasThreads(int threads) {
    if (threads <= 0) return;
    active_ = true;
    const Api& api = openblas();
    if (api.get && api.set) {
      saved_blas_ = api.get();
      api.set(threads);
    }
  }
  ~ScopedBlasThreads() {
    if (!active_) return;
    const Api& api = openblas();
    if (api.set && saved_blas_ > 0) api.set(saved_blas_);
  }
  ScopedBlasThreads(const ScopedBlasThreads&) = delete;
  ScopedBlasThreads& operator=(const ScopedBlasThreads&) = delete;

 private:
  struct Api {
    int (*get)() = nullptr;
    void (*set)(int) = nullptr;
  };
  static const Api& openblas() {
    static const Api api = [] {
      Api a;
      a.get = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
      a.set = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
      return a;
    }();
    return api;
  }
  bool active_ = false;
  int saved_blas_ = 0;
};

}  // namespace rbc
