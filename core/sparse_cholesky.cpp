// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/sparse_cholesky.hpp"

#include <malloc.h>
#include <pthread.h>
#include <sys/mman.h>

#include <Eigen/CholmodSupport>
#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/blas_threads.hpp"
#include "core/supernodal_factor.hpp"
#include "core/supernodal_solve.hpp"
#include "core/validation.hpp"

namespace rbc {

void SparseCholeskyOptions::validate() const {
  require_integer_in_range("Cholesky supernodal threshold (unknowns)", supernodal_min_unknowns, 0,
                           std::numeric_limits<int>::max());
  require_integer_in_range("Cholesky relaxed-amalgamation threshold (unknowns)",
                           relaxed_amalgamation_below, 0, std::numeric_limits<int>::max());
  require_integer_in_range("Cholesky BLAS threads (0 = the caller's)", blas_threads, 0, 1024);
}

namespace detail {

/// CHOLMOD's allocator (SuiteSparse_config, installed once per process before the first
/// CHOLMOD call: SparseCholesky is the project's only CHOLMOD user). Blocks of at least
/// kHugeBlockBytes (the factor, its update workspace) get a mapping of their own, aligned to
/// 2 MiB, on which transparent huge pages are asked for (madvise; the kernel's default policy
/// here): their first touch then faults once per 2 MiB instead of once per 4 KiB page. On this
/// project's VMs a 4 KiB fault costs 11 us, so the first factorisation of the full spectrin level
/// (300 MB of factor) spent 0.8 s in page faults (README, "Sparse Cholesky: the factor on huge
/// pages"). Smaller blocks come from malloc as before. A realloc that stays within its block's
/// 2 MiB-rounded length resizes in place. Nothing may call SuiteSparse_start() once they are
/// installed (nothing in the project does; CHOLMOD 3's cholmod_start does not): it resets the
/// hooks to the C library's, whose free() must not see a mapped block.
namespace huge {
namespace {  // internal linkage: this file alone uses them
constexpr size_t kPageBytes = size_t{2} << 20;
constexpr size_t kHugeBlockBytes = size_t{4} << 20;
/// Freed mappings kept for reuse, at most this many bytes and blocks: CHOLMOD maps its update
/// workspace afresh at every numeric factorisation (23 MB at the full spectrin level, 4 MB at
/// 9,680 continuum elements), whose pages would otherwise fault in again each time (without
/// transparent huge pages, ~3,500 faults of ~11 us per factorisation of a 104 MB factor).
constexpr size_t kIdleBytes = size_t{64} << 20;
constexpr size_t kIdleBlocks = 4;
struct Block {
  size_t bytes = 0;   ///< requested
  size_t length = 0;  ///< mapped (a multiple of kPageBytes)
};
struct Registry {
  std::mutex mutex;
  std::unordered_map<void*, Block> live;
  std::vector<std::pair<void*, size_t>> idle;  ///< freed mappings and their lengths
  size_t idle_bytes = 0;
};
/// Never destroyed: a block freed during static destruction still finds it.
Registry& registry() {
  static Registry* r = new Registry;
  return *r;
}
size_t mapped_bytes(size_t bytes) {
  return (bytes + kPageBytes - 1) / kPageBytes * kPageBytes;
}
/// A block of `bytes` (>= kHugeBlockBytes) on a 2 MiB-aligned mapping of its own: a kept idle
/// one of the same length, else a new one. `zeroed`: its first `bytes` read 0 (new mappings
/// start zeroed). Null when the size is not representable or the kernel refuses.
void* map_block(size_t bytes, bool zeroed) {
  if (bytes > std::numeric_limits<size_t>::max() - 2 * kPageBytes) return nullptr;
  const size_t length = mapped_bytes(bytes);
  Registry& reg = registry();
  void* reused = nullptr;
  {
    const std::lock_guard<std::mutex> lock(reg.mutex);
    for (auto it = reg.idle.begin(); it != reg.idle.end(); ++it)
      if (it->second == length) {
        reused = it->first;
        reg.idle.erase(it);
        reg.idle_bytes -= length;
        break;
      }
    if (reused) {
      try {
        reg.live.emplace(reused, Block{bytes, length});
      } catch (...) {
        munmap(reused, length);
        return nullptr;
      }
    }
  }
  if (reused) {
    if (zeroed) std::memset(reused, 0, bytes);
    return reused;
  }
  void* raw = mmap(nullptr, length + kPageBytes, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) return nullptr;
  const auto start = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = (start + kPageBytes - 1) / kPageBytes * kPageBytes;
  const size_t head = aligned - start;
  if (head > 0) munmap(raw, head);
  if (kPageBytes - head > 0) munmap(reinterpret_cast<char*>(aligned) + length, kPageBytes - head);
  void* block = reinterpret_cast<void*>(aligned);
  madvise(block, length, MADV_HUGEPAGE);  // advice only: without it the block still works
  bool registered = false;
  try {
    const std::lock_guard<std::mutex> lock(reg.mutex);
    registered = reg.live.emplace(block, Block{bytes, length}).second;
  } catch (...) {
  }
  if (!registered) {  // out of memory, or an address already live (cannot happen)
    munmap(block, length);
    return nullptr;
  }
  return block;
}
/// The requested size of a huge block, 0 for any other pointer.
size_t block_bytes(void* p) {
  Registry& reg = registry();
  const std::lock_guard<std::mutex> lock(reg.mutex);
  const auto it = reg.live.find(p);
  return it == reg.live.end() ? 0 : it->second.bytes;
}
void* allocate(size_t bytes) {
  return bytes >= kHugeBlockBytes ? map_block(bytes, false) : std::malloc(bytes);
}
void* allocate_zeroed(size_t count, size_t size) {
  if (size != 0 && count > std::numeric_limits<size_t>::max() / size) return nullptr;
  return count * size >= kHugeBlockBytes ? map_block(count * size, true) : std::calloc(count, size);
}
void release(void* p) {
  if (!p) return;
  {
    Registry& reg = registry();
    const std::lock_guard<std::mutex> lock(reg.mutex);
    const auto it = reg.live.find(p);
    if (it != reg.live.end()) {
      const size_t length = it->second.length;
      reg.live.erase(it);
      bool kept = false;
      if (reg.idle.size() < kIdleBlocks && length <= kIdleBytes - reg.idle_bytes) {
        try {
          reg.idle.emplace_back(p, length);
          reg.idle_bytes += length;
          kept = true;
        } catch (...) {
        }
      }
      if (!kept) munmap(p, length);
      return;
    }
  }
  std::free(p);
}
/// Resizes a huge block in place when `bytes` (>= kHugeBlockBytes) still fits its mapping's
/// length rounded the same way (e.g. 5 -> 5.5 MiB on a 6 MiB mapping): true, and the block
/// now holds `bytes`. False for any other pointer or size.
bool resize_in_place(void* p, size_t bytes) {
  if (bytes < kHugeBlockBytes) return false;
  Registry& reg = registry();
  const std::lock_guard<std::mutex> lock(reg.mutex);
  const auto it = reg.live.find(p);
  if (it == reg.live.end() || mapped_bytes(bytes) != it->second.length) return false;
  it->second.bytes = bytes;
  return true;
}
void* reallocate(void* p, size_t bytes) {
  if (!p) return allocate(bytes);
  if (resize_in_place(p, bytes)) return p;
  const size_t old = block_bytes(p);
  if (old == 0 && bytes < kHugeBlockBytes) return std::realloc(p, bytes);
  void* q = allocate(bytes);
  if (!q) return nullptr;  // p stays valid, as realloc leaves it
  std::memcpy(q, p, std::min(old > 0 ? old : malloc_usable_size(p), bytes));
  release(p);
  return q;
}
void install() {
  static std::once_flag once;
  std::call_once(once, [] {
    SuiteSparse_config.malloc_func = allocate;
    SuiteSparse_config.calloc_func = allocate_zeroed;
    SuiteSparse_config.realloc_func = reallocate;
    SuiteSparse_config.free_func = release;
  });
}
}  // namespace
}  // namespace huge

namespace {
/// CHOLMOD's view of an n x n lower triangle in CSC arrays with sorted rows (no copy; CHOLMOD
/// reads them only). values null: the pattern alone.
cholmod_sparse lower_csc_view(int n, const int* outer, const int* inner, double* values) {
  cholmod_sparse a{};
  a.nrow = a.ncol = static_cast<size_t>(n);
  a.nzmax = static_cast<size_t>(outer[n]);
  a.p = const_cast<int*>(outer);
  a.i = const_cast<int*>(inner);
  a.x = values;
  a.stype = -1;
  a.itype = CHOLMOD_INT;
  a.xtype = values ? CHOLMOD_REAL : CHOLMOD_PATTERN;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;
  return a;
}
}  // namespace

/// Eigen's CHOLMOD wrapper with a deep copy: Eigen offers none, and a kept factorisation must
/// survive while its original is refactorised (SparseCholesky::clone). The copy is CHOLMOD's own
/// (cholmod_copy_factor), of the symbolic analysis and the numeric factor alike.
class CopyableCholmod final
    : public Eigen::CholmodDecomposition<Eigen::SparseMatrix<double>, Eigen::Lower> {
 public:
  /// Makes this a copy of other's analysis and factor (this object's common must already be
  /// configured as other's: same mode and ordering).
  void copy_factor_of(const CopyableCholmod& other) {
    if (m_cholmodFactor) cholmod_free_factor(&m_cholmodFactor, &cholmod());
    m_cholmodFactor =
        other.m_cholmodFactor ? cholmod_copy_factor(other.m_cholmodFactor, &cholmod()) : nullptr;
    if (other.m_cholmodFactor && !m_cholmodFactor) throw std::bad_alloc();
    m_isInitialized = other.m_isInitialized;
    // Eigen's cholmod() is not const; the other's common is only read.
    cholmod().lnz = const_cast<CopyableCholmod&>(other).cholmod().lnz;
    m_info = other.m_info;
    m_analysisIsOk = other.m_analysisIsOk && m_cholmodFactor;
    m_factorizationIsOk = other.m_factorizationIsOk && m_cholmodFactor;
    m_shiftOffset[0] = other.m_shiftOffset[0];
    m_shiftOffset[1] = other.m_shiftOffset[1];
  }
  /// Symbolic analysis of the lower triangle given by CSC arrays (n x n, rows sorted in each
  /// column) with this object's settings. False if CHOLMOD made no factor (e.g. no memory).
  bool analyze_lower(int n, const int* outer, const int* inner, double* values) {
    if (m_cholmodFactor) cholmod_free_factor(&m_cholmodFactor, &cholmod());
    m_cholmodFactor = nullptr;
    cholmod_sparse a = lower_view(n, outer, inner, values);
    m_cholmodFactor = cholmod_analyze(&a, &cholmod());
    m_isInitialized = true;
    m_analysisIsOk = m_cholmodFactor != nullptr;
    m_factorizationIsOk = false;
    m_info = m_analysisIsOk ? Eigen::Success : Eigen::NumericalIssue;
    return m_analysisIsOk;
  }
  /// Symbolic analysis of a's lower triangle (a compressed; entries above the diagonal are
  /// ignored) in the order `perm` (L L' = a(perm, perm) before CHOLMOD's postorder, if this
  /// object's common asks for one). False if CHOLMOD made no factor.
  bool analyze_given(const Eigen::SparseMatrix<double>& a, std::vector<int>& perm) {
    if (m_cholmodFactor) cholmod_free_factor(&m_cholmodFactor, &cholmod());
    m_cholmodFactor = nullptr;
    cholmod_sparse view = lower_view(static_cast<int>(a.rows()), a.outerIndexPtr(),
                                     a.innerIndexPtr(), const_cast<double*>(a.valuePtr()));
    cholmod().nmethods = 1;
    cholmod().method[0].ordering = CHOLMOD_GIVEN;
    m_cholmodFactor = cholmod_analyze_p(&view, perm.data(), nullptr, 0, &cholmod());
    m_isInitialized = true;
    m_analysisIsOk = m_cholmodFactor != nullptr;
    m_factorizationIsOk = false;
    m_info = m_analysisIsOk ? Eigen::Success : Eigen::NumericalIssue;
    return m_analysisIsOk;
  }
  /// Numeric factorisation of that matrix + shift I (CHOLMOD's beta), on the analysis made by
  /// analyze_lower. True if the shifted matrix is positive definite.
  bool factorize_lower(int n, const int* outer, const int* inner, double* values, double shift) {
    if (!m_cholmodFactor) return false;
    cholmod_sparse a = lower_view(n, outer, inner, values);
    m_shiftOffset[0] = shift;
    m_shiftOffset[1] = 0.0;
    cholmod_factorize_p(&a, m_shiftOffset, nullptr, 0, m_cholmodFactor, &cholmod());
    m_factorizationIsOk = true;
    m_info = m_cholmodFactor->minor == m_cholmodFactor->n ? Eigen::Success : Eigen::NumericalIssue;
    return m_info == Eigen::Success;
  }
  bool has_factor() const { return m_cholmodFactor != nullptr; }
  /// CHOLMOD's factor (null before an analysis), read only.
  const cholmod_factor* raw() const { return m_cholmodFactor; }
  /// The fill-reducing permutation of the analysis (L L' = A(perm, perm)); null without one.
  const int* permutation() const {
    return m_cholmodFactor ? static_cast<const int*>(m_cholmodFactor->Perm) : nullptr;
  }
  /// Entries CHOLMOD keeps for L (supernodal: xsize, the dense supernode blocks; simplicial:
  /// the column counts, without the allocation's slack); 0 without a factor.
  double storage() const {
    const cholmod_factor* l = m_cholmodFactor;
    if (!l) return 0.0;
    if (l->is_super) return static_cast<double>(l->xsize);
    double sum = 0.0;
    if (l->nz)
      for (size_t j = 0; j < l->n; ++j)
        sum += static_cast<double>(static_cast<const int*>(l->nz)[j]);
    return sum;
  }

 private:
  static cholmod_sparse lower_view(int n, const int* outer, const int* inner, double* values) {
    return lower_csc_view(n, outer, inner, values);
  }
};

/// The analysis of one pattern, shared by a SparseCholesky and its clones (it never changes).
/// CHOLMOD's supernodal factorisation of a lower triangle in the caller's order copies the
/// matrix twice per call (cholmod_ptranspose: A(p,p)' upper, then back to lower); given the
/// lower triangle already in its order, with the natural ordering, it reads it where it lies.
struct PermutedPattern {
  int n = 0;
  std::vector<int> perm;              ///< CHOLMOD's order: L L' = a(perm, perm)
  std::vector<int> outer, inner;      ///< the permuted lower triangle (CSC, rows sorted)
  std::vector<int> gather;            ///< per stored value of a: its place, -1 above the diagonal
  std::vector<int> a_outer, a_inner;  ///< the caller's pattern (a changed one is re-analysed)
  bool matches(const Eigen::SparseMatrix<double>& a) const {
    return a.rows() == n && a.cols() == n &&
           std::equal(a_outer.begin(), a_outer.end(), a.outerIndexPtr()) &&
           a.nonZeros() == static_cast<Eigen::Index>(a_inner.size()) &&
           std::equal(a_inner.begin(), a_inner.end(), a.innerIndexPtr());
  }
};

namespace {  // internal linkage, as the allocator
/// The block size b in {3, 2} of which a's lower triangle is made: every stored entry (r, c),
/// r >= c, lies in a block (r / b, c / b) stored whole (its lower half on the diagonal). 1 if
/// neither. Needs a compressed matrix (no duplicate entries).
int full_block_size(const Eigen::SparseMatrix<double>& a) {
  const int n = static_cast<int>(a.rows());
  const int* outer = a.outerIndexPtr();
  const int* inner = a.innerIndexPtr();
  std::vector<int> stamp;
  for (int b : {3, 2}) {
    if (n == 0 || n % b != 0) continue;
    const int blocks = n / b;
    stamp.assign(static_cast<size_t>(blocks), -1);
    bool full = true;
    for (int bc = 0; bc < blocks && full; ++bc) {
      long long stored = 0, off_diagonal = 0;
      bool diagonal = false;
      for (int c = b * bc; c < b * bc + b; ++c)
        for (int k = outer[c]; k < outer[c + 1]; ++k) {
          if (inner[k] < c) continue;
          ++stored;
          const int br = inner[k] / b;
          if (br == bc) {
            diagonal = true;
          } else if (stamp[static_cast<size_t>(br)] != bc) {
            stamp[static_cast<size_t>(br)] = bc;
            ++off_diagonal;
          }
        }
      full = stored == off_diagonal * b * b + (diagonal ? b * (b + 1) / 2 : 0);
    }
    if (full) return b;
  }
  return 1;
}

/// METIS's nested-dissection order of the graph of a's b x b blocks (b = full_block_size(a)
/// > 1), expanded to the unknowns (each block's b unknowns in turn); CHOLMOD's postorder of
/// the elimination tree follows in the analysis. Empty if CHOLMOD's METIS call failed.
std::vector<int> block_metis_order(const Eigen::SparseMatrix<double>& a, int b,
                                   cholmod_common& common) {
  const int n = static_cast<int>(a.rows());
  const int blocks = n / b;
  const int* outer = a.outerIndexPtr();
  const int* inner = a.innerIndexPtr();
  // The blocks' lower pattern (block rows sorted and distinct in each block column).
  std::vector<int> bp(static_cast<size_t>(blocks) + 1, 0), bi,
      stamp(static_cast<size_t>(blocks), -1);
  bi.reserve(static_cast<size_t>(a.nonZeros() / (b * b) + blocks));
  for (int bc = 0; bc < blocks; ++bc) {
    const size_t begin = bi.size();
    for (int c = b * bc; c < b * bc + b; ++c)
      for (int k = outer[c]; k < outer[c + 1]; ++k) {
        const int br = inner[k] / b;
        if (inner[k] >= c && stamp[static_cast<size_t>(br)] != bc) {
          stamp[static_cast<size_t>(br)] = bc;
          bi.push_back(br);
        }
      }
    std::sort(bi.begin() + static_cast<std::ptrdiff_t>(begin), bi.end());
    bp[static_cast<size_t>(bc) + 1] = static_cast<int>(bi.size());
  }
  cholmod_sparse g = lower_csc_view(blocks, bp.data(), bi.data(), nullptr);
  std::vector<int> block_perm(static_cast<size_t>(blocks), -1);
  if (!cholmod_metis(&g, nullptr, 0, 0, block_perm.data(), &common)) return {};
  // CHOLMOD does not look at METIS's return code: a failed METIS (out of memory, an internal
  // error) leaves an incomplete order, which must not reach the analysis.
  std::vector<char> seen(static_cast<size_t>(blocks), 0);
  for (const int k : block_perm) {
    if (k < 0 || k >= blocks || seen[static_cast<size_t>(k)]) return {};
    seen[static_cast<size_t>(k)] = 1;
  }
  std::vector<int> perm(static_cast<size_t>(n));
  for (int k = 0; k < blocks; ++k)
    for (int d = 0; d < b; ++d)
      perm[static_cast<size_t>(b * k + d)] = b * block_perm[static_cast<size_t>(k)] + d;
  return perm;
}

/// Whether SIGTERM is pending on this thread alone (thread-directed: raise, tgkill), from the
/// "SigPnd" line of /proc/thread-self/status (the process-directed ones are on "ShdPnd").
bool sigterm_pending_on_this_thread() {
  std::FILE* f = std::fopen("/proc/thread-self/status", "r");
  if (!f) return false;
  char line[256];
  unsigned long long mask = 0;
  bool found = false;
  while (!found && std::fgets(line, sizeof line, f))
    found = std::sscanf(line, "SigPnd: %llx", &mask) == 1;
  std::fclose(f);
  return found && (mask >> (SIGTERM - 1) & 1ull) != 0;
}

/// Whether METIS reported an error through SIGTERM that is still pending on this thread; the
/// signal is consumed. METIS (GKlib's gk_errexit) raises SIGTERM at the calling thread for the
/// handler it installs around an ordering, which longjmps out of it. Where the thread blocks
/// SIGTERM (the rbc executable takes it on a signal thread: app/interrupt.hpp) no handler runs:
/// the signal stays pending on this thread and METIS returns normally. A SIGTERM sent to the
/// process (kill) is left for the signal thread. Process-wide signal state is read because
/// METIS reports through it.
bool take_raised_sigterm() {
  sigset_t blocked, pending, term;
  if (pthread_sigmask(SIG_BLOCK, nullptr, &blocked) != 0 || !sigismember(&blocked, SIGTERM))
    return false;  // not blocked: METIS's own handler took it
  if (sigpending(&pending) != 0 || !sigismember(&pending, SIGTERM) ||
      !sigterm_pending_on_this_thread())
    return false;
  sigemptyset(&term);
  sigaddset(&term, SIGTERM);
  const timespec now{0, 0};
  // The thread's own pending signals are dequeued before the process's.
  return sigtimedwait(&term, nullptr, &now) == SIGTERM;
}

/// Throws if an ordering just made on this thread failed with METIS's error signal.
void check_ordering_signal(int unknowns) {
  if (take_raised_sigterm())
    throw std::runtime_error("sparse Cholesky: the fill-reducing ordering (METIS) failed on " +
                             std::to_string(unknowns) + " unknowns");
}

}  // namespace
}  // namespace detail

struct SparseCholesky::Impl {
  SparseCholeskyOptions options;
  /// Analysed and factorised on the permuted lower triangle in the natural order.
  detail::CopyableCholmod factor;
  bool analysed = false, ok = false;
  Eigen::Index n = 0;
  int block_size = 1;  ///< the blocks the last analysis ordered (1: the unknowns)
  int analyses = 0;    ///< symbolic analyses made (SparseCholesky::analyses)
  std::shared_ptr<const detail::PermutedPattern> pattern;
  std::vector<double> values;  ///< the permuted matrix's values (allocated at a factorisation)
  /// The factor rounded to float (SolvePrecision::single_precision, supernodal factors only;
  /// used when single_ready) and the analysis its structure was copied from.
  SinglePrecisionFactor single;
  bool single_ready = false;
  int single_analysis = -1;
  /// SolvePrecision::single_precision_factorisation: the float factorisation's workspace;
  /// whether CHOLMOD's double factor holds the current factorisation too (made lazily, for a
  /// right-hand side whose float solve leaves float's range); the current shift.
  SupernodalFactorWorkspace single_work;
  bool double_ready = false;
  double shift = 0.0;

  /// Copies the supernodal structure of the analysis into `single` (once per analysis). False
  /// for a simplicial analysis or a build without the float solves.
  bool copy_structure() {
    const cholmod_factor* l = factor.raw();
    if (!l || !l->is_super || !single_precision_solves_available()) return false;
    const int nsuper = static_cast<int>(l->nsuper);
    if (single_analysis == analyses && single.supernodes() == nsuper) return true;
    const int* super = static_cast<const int*>(l->super);
    const int* pi = static_cast<const int*>(l->pi);
    const int* px = static_cast<const int*>(l->px);
    single.n = static_cast<int>(l->n);
    single.super.assign(super, super + nsuper + 1);
    single.row_start.assign(pi, pi + nsuper + 1);
    single.value_start.assign(px, px + nsuper + 1);
    const int* rows = static_cast<const int*>(l->s);
    single.rows.assign(rows, rows + pi[nsuper]);
    single.max_rows = 0;
    for (int k = 0; k < nsuper; ++k) single.max_rows = std::max(single.max_rows, pi[k + 1] - pi[k]);
    single_analysis = analyses;
    single_work = SupernodalFactorWorkspace{};
    return true;
  }

  /// The double factorisation of the current matrix (CHOLMOD), if not made yet.
  bool ensure_double() {
    if (double_ready) return true;
    const detail::PermutedPattern& pat = *pattern;
    const ScopedBlasThreads blas(options.blas_threads);
    double_ready =
        factor.factorize_lower(pat.n, pat.outer.data(), pat.inner.data(), values.data(), shift);
    return double_ready;
  }

  /// Solves the permuted system in place: in float where single_ready (in double where that
  /// result is not finite), else in double.
  void solve_permuted(Eigen::VectorXd& xp) {
    if (single_ready) {
      const Eigen::VectorXd bp = xp;
      solve_in_place(single, xp.data());
      // A non-finite right-hand side gives a non-finite answer in any precision: no double
      // factorisation for it.
      if (xp.allFinite() || !bp.allFinite()) return;
      xp = bp;  // beyond float's range: in double
      if (!ensure_double())
        throw std::runtime_error(
            "sparse Cholesky: the double factorisation of a matrix factorised in float failed");
    }
    xp = factor.solve(Eigen::VectorXd(xp));
  }

  /// Rounds the (successful) factor to float into `single`, its structure copied once per
  /// analysis. A simplicial factor, or one with an entry or inverse pivot beyond float's range,
  /// leaves single_ready false (solved in double). Entries below float's smallest normal number
  /// become 0 (a subnormal operand costs a microcode assist per use on x86).
  void round_factor() {
    single_ready = false;
    const cholmod_factor* l = factor.raw();
    if (!l || l->xtype != CHOLMOD_REAL || !copy_structure()) return;
    const int nsuper = static_cast<int>(l->nsuper);
    const int* super = static_cast<const int*>(l->super);
    const int* pi = static_cast<const int*>(l->pi);
    const int* px = static_cast<const int*>(l->px);
    const double* x = static_cast<const double*>(l->x);
    const size_t entries = static_cast<size_t>(px[nsuper]);
    single.values.resize(entries);
    constexpr float kLargest = std::numeric_limits<float>::max();
    constexpr float kSmallest = std::numeric_limits<float>::min();
    bool representable = true;
    for (size_t k = 0; k < entries; ++k) {
      const float f = static_cast<float>(x[k]);
      single.values[k] = std::abs(f) < kSmallest ? 0.0f : f;
      representable &= std::abs(f) <= kLargest;
    }
    single.inverse_diagonal.resize(static_cast<size_t>(single.n));
    for (int k = 0; k < nsuper; ++k) {
      const size_t nrow = static_cast<size_t>(pi[k + 1] - pi[k]);
      for (int j = super[k]; j < super[k + 1]; ++j) {
        const size_t c = static_cast<size_t>(j - super[k]);
        const float inv = static_cast<float>(1.0 / x[static_cast<size_t>(px[k]) + c * nrow + c]);
        single.inverse_diagonal[static_cast<size_t>(j)] = inv;
        representable &= std::abs(inv) <= kLargest && std::abs(inv) >= kSmallest;
      }
    }
    single_ready = representable;
  }

  /// Configures f for `unknowns` unknowns. `natural`: the analysis of the permuted matrix (no
  /// ordering and no postorder: the order of `permuted` is already CHOLMOD's postordered one);
  /// else the ordering of the options, on a fresh object.
  void configure(detail::CopyableCholmod& f, Eigen::Index unknowns, bool natural) const {
    f.setMode(unknowns >= options.supernodal_min_unknowns ? Eigen::CholmodSupernodalLLt
                                                          : Eigen::CholmodSimplicialLLt);
    if (natural) {
      f.cholmod().nmethods = 1;
      f.cholmod().method[0].ordering = CHOLMOD_NATURAL;
      f.cholmod().postorder = 0;
    } else {
      switch (options.ordering) {
        case FillOrdering::automatic:
          break;
        case FillOrdering::amd:
        case FillOrdering::metis:
        case FillOrdering::nested_dissection:
          f.cholmod().nmethods = 1;
          f.cholmod().method[0].ordering = options.ordering == FillOrdering::amd ? CHOLMOD_AMD
                                           : options.ordering == FillOrdering::metis
                                               ? CHOLMOD_METIS
                                               : CHOLMOD_NESDIS;
          break;
      }
    }
    // Library code does not print: a failed (indefinite) trial is expected and handled by
    // the caller's shift loop.
    f.cholmod().print = 0;
    // Supernode amalgamation (SparseCholeskyOptions::relaxed_amalgamation_below): CHOLMOD's
    // defaults, or 4 times the columns and twice the zero fraction a supernode may absorb.
    const bool relaxed = unknowns < options.relaxed_amalgamation_below;
    const size_t nrelax[3] = {4, 16, 48};
    const double zrelax[3] = {0.8, 0.1, 0.05};
    for (int i = 0; i < 3; ++i) {
      f.cholmod().nrelax[i] = relaxed ? 4 * nrelax[i] : nrelax[i];
      f.cholmod().zrelax[i] = relaxed ? 2 * zrelax[i] : zrelax[i];
    }
  }
};

std::unique_lock<std::mutex> lock_fill_ordering() {
  static std::mutex m;
  return std::unique_lock<std::mutex>(m);
}

SparseCholesky::SparseCholesky(const SparseCholeskyOptions& options)
    : impl_((detail::huge::install(), std::make_unique<Impl>())) {
  options.validate();
  impl_->options = options;
}
SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

SparseCholesky SparseCholesky::clone() const {
  SparseCholesky c(impl_->options);
  if (impl_->analysed) {
    c.impl_->configure(c.impl_->factor, impl_->n, true);
    c.impl_->factor.copy_factor_of(impl_->factor);
    c.impl_->pattern =
        impl_->pattern;  // shared; the values are the copy's own when it refactorises
    c.impl_->analysed = true;
    c.impl_->ok = impl_->ok;
    c.impl_->n = impl_->n;
    c.impl_->block_size = impl_->block_size;
    c.impl_->single = impl_->single;
    c.impl_->single_ready = impl_->single_ready;
    c.impl_->single_analysis = impl_->single_analysis;
    c.impl_->double_ready = impl_->double_ready;
    c.impl_->shift = impl_->shift;
    // The matrix's values only where the copy may still need its double factorisation (a float
    // factor without one: ensure_double); a refactorisation rewrites them all.
    if (impl_->single_ready && !impl_->double_ready) c.impl_->values = impl_->values;
  }
  c.impl_->analyses = impl_->analyses;
  return c;
}

void SparseCholesky::analyze(const Eigen::SparseMatrix<double>& a) {
  if (a.rows() != a.cols())
    throw std::invalid_argument("sparse Cholesky: matrix must be square, got " +
                                std::to_string(a.rows()) + " x " + std::to_string(a.cols()));
  if (!a.isCompressed()) {
    Eigen::SparseMatrix<double> compressed = a;
    compressed.makeCompressed();
    analyze(compressed);
    return;
  }
  Impl& m = *impl_;
  if (a.rows() > std::numeric_limits<int>::max() / 2)
    throw std::invalid_argument("sparse Cholesky: " + std::to_string(a.rows()) +
                                " unknowns exceed the 32-bit indices");
  const int n = static_cast<int>(a.rows());
  m.analysed = m.ok = false;
  auto pat = std::make_shared<detail::PermutedPattern>();
  pat->n = n;
  // 1. CHOLMOD's ordering of a (METIS or AMD, then its etree postorder).
  {
    detail::CopyableCholmod ordering;
    m.configure(ordering, n, false);
    // Only the permutation is kept: the simplicial analysis skips the supernodal symbolic
    // pass (the ordering and its postorder are the same in both modes).
    ordering.setMode(Eigen::CholmodSimplicialLLt);
    // METIS on the blocks' graph where a is made of vertex blocks (same fill, b^2 times fewer
    // edges to partition), then the analysis in that order (with CHOLMOD's postorder).
    const int b = m.options.block_ordering && m.options.ordering == FillOrdering::metis
                      ? detail::full_block_size(a)
                      : 1;
    std::vector<int> given;
    {
      const auto lock = lock_fill_ordering();
      if (b > 1) given = detail::block_metis_order(a, b, ordering.cholmod());
      detail::check_ordering_signal(n);
      if (!given.empty())
        ordering.analyze_given(a, given);
      else
        ordering.analyzePattern(a);
      detail::check_ordering_signal(n);
    }
    m.block_size = given.empty() ? 1 : b;
    if (!ordering.has_factor() || (n > 0 && !ordering.permutation()))
      throw std::runtime_error("sparse Cholesky: CHOLMOD's symbolic analysis failed (" +
                               std::to_string(n) + " unknowns)");
    pat->perm.assign(ordering.permutation(), ordering.permutation() + n);
  }
  std::vector<int> inverse(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) inverse[static_cast<size_t>(pat->perm[static_cast<size_t>(k)])] = k;
  // 2. The permuted lower pattern, and where each stored value of a goes in it.
  const int* outer = a.outerIndexPtr();
  const int* inner = a.innerIndexPtr();
  pat->a_outer.assign(outer, outer + n + 1);
  pat->a_inner.assign(inner, inner + a.nonZeros());
  std::vector<int>& count = pat->outer;
  count.assign(static_cast<size_t>(n) + 1, 0);
  for (int j = 0; j < n; ++j)
    for (int k = outer[j]; k < outer[j + 1]; ++k)
      if (inner[k] >= j) ++count[static_cast<size_t>(std::min(inverse[inner[k]], inverse[j])) + 1];
  for (int j = 0; j < n; ++j) count[j + 1] += count[j];
  pat->inner.assign(static_cast<size_t>(count[static_cast<size_t>(n)]), 0);
  pat->gather.assign(static_cast<size_t>(a.nonZeros()), -1);
  std::vector<int> next(count.begin(), count.end() - 1);  // fill cursor per column
  for (int j = 0; j < n; ++j)                             // rows in the caller's column order ...
    for (int k = outer[j]; k < outer[j + 1]; ++k)
      if (inner[k] >= j) {
        const int r = std::max(inverse[inner[k]], inverse[j]);
        const int c = std::min(inverse[inner[k]], inverse[j]);
        pat->gather[static_cast<size_t>(k)] = next[static_cast<size_t>(c)];
        pat->inner[static_cast<size_t>(next[static_cast<size_t>(c)]++)] = r;
      }
  // ... then sorted within each column (CHOLMOD wants sorted rows), the gather map following.
  std::vector<int> order, position(pat->inner.size()), rows;
  for (int c = 0; c < n; ++c) {
    const int begin = count[static_cast<size_t>(c)], end = count[static_cast<size_t>(c) + 1];
    order.resize(static_cast<size_t>(end - begin));
    for (int k = begin; k < end; ++k) order[static_cast<size_t>(k - begin)] = k;
    const int* row = pat->inner.data();
    std::sort(order.begin(), order.end(), [row](int x, int y) { return row[x] < row[y]; });
    rows.resize(order.size());
    for (size_t q = 0; q < order.size(); ++q) {
      rows[q] = row[order[q]];
      position[static_cast<size_t>(order[q])] = begin + static_cast<int>(q);
    }
    std::copy(rows.begin(), rows.end(), pat->inner.begin() + begin);
  }
  for (int& g : pat->gather)
    if (g >= 0) g = position[static_cast<size_t>(g)];
  // 3. The analysis of the permuted matrix in its own order: the same elimination tree and
  // supernodes, so the same factor as CHOLMOD's permuted path, bit for bit.
  m.configure(m.factor, n, true);
  m.values.assign(pat->inner.size(), 0.0);
  if (!m.factor.analyze_lower(n, pat->outer.data(), pat->inner.data(), m.values.data()))
    throw std::runtime_error("sparse Cholesky: CHOLMOD's symbolic analysis failed (" +
                             std::to_string(n) + " unknowns)");
  m.pattern = std::move(pat);
  m.analysed = true;
  ++m.analyses;
  m.n = n;
}

bool SparseCholesky::factorize(const Eigen::SparseMatrix<double>& a, double diagonal_shift) {
  if (!std::isfinite(diagonal_shift))
    throw std::invalid_argument("sparse Cholesky: diagonal shift must be finite, got " +
                                std::to_string(diagonal_shift));
  if (!a.isCompressed()) {
    Eigen::SparseMatrix<double> compressed = a;
    compressed.makeCompressed();
    return factorize(compressed, diagonal_shift);
  }
  Impl& m = *impl_;
  if (!m.analysed || !m.pattern->matches(a)) analyze(a);
  const detail::PermutedPattern& pat = *m.pattern;
  m.values.resize(pat.inner.size());
  const double* v = a.valuePtr();
  double* p = m.values.data();
  bool finite = true;
  for (size_t k = 0; k < pat.gather.size(); ++k)
    if (pat.gather[k] >= 0) {
      p[pat.gather[k]] = v[k];
      finite &= std::isfinite(v[k]);
    }
  m.shift = diagonal_shift;
  m.single_ready = m.double_ready = false;
  // A non-finite entry: not positive definite (CHOLMOD's supernodal factorisation through
  // OpenBLAS's dpotrf let a NaN pivot through as a success, and its factor was NaN).
  if (!finite) return m.ok = false;
  const ScopedBlasThreads blas(m.options.blas_threads);
  if (m.options.solve_precision == SolvePrecision::single_precision_factorisation &&
      m.copy_structure()) {
    switch (factorize_single(pat.outer.data(), pat.inner.data(), p, diagonal_shift, m.single,
                             m.single_work)) {
      case SingleFactorStatus::factorised:
        m.ok = m.single_ready = true;
        return true;
      case SingleFactorStatus::not_positive_definite:
        m.ok = false;
        return false;
      case SingleFactorStatus::out_of_range:
        break;  // in double
    }
  }
  m.ok = m.factor.factorize_lower(pat.n, pat.outer.data(), pat.inner.data(), p, diagonal_shift);
  m.double_ready = m.ok;
  if (m.ok && m.options.solve_precision == SolvePrecision::single_precision) m.round_factor();
  return m.ok;
}

bool SparseCholesky::factorised() const {
  return impl_->ok;
}

Eigen::VectorXd SparseCholesky::solve(const Eigen::VectorXd& b) const {
  if (!impl_->ok) throw std::logic_error("sparse Cholesky: solve without a factorisation");
  if (b.rows() != impl_->n)
    throw std::invalid_argument("sparse Cholesky: right-hand side of " + std::to_string(b.rows()) +
                                " rows for " + std::to_string(impl_->n) + " unknowns");
  const ScopedBlasThreads blas(impl_->options.blas_threads);
  const std::vector<int>& perm = impl_->pattern->perm;
  Eigen::VectorXd bp(b.rows());
  for (Eigen::Index k = 0; k < b.rows(); ++k) bp(k) = b(perm[k]);
  impl_->solve_permuted(bp);
  const Eigen::VectorXd& xp = bp;
  Eigen::VectorXd x(b.rows());
  for (Eigen::Index k = 0; k < b.rows(); ++k) x(perm[k]) = xp(k);
  return x;
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& b) const {
  if (!impl_->ok) throw std::logic_error("sparse Cholesky: solve without a factorisation");
  if (b.rows() != impl_->n)
    throw std::invalid_argument("sparse Cholesky: right-hand side of " + std::to_string(b.rows()) +
                                " rows for " + std::to_string(impl_->n) + " unknowns");
  const ScopedBlasThreads blas(impl_->options.blas_threads);
  const std::vector<int>& perm = impl_->pattern->perm;
  Eigen::MatrixXd bp(b.rows(), b.cols());
  for (Eigen::Index k = 0; k < b.rows(); ++k) bp.row(k) = b.row(perm[k]);
  // A few right-hand sides on a factor that stays in cache: one column at a time. CHOLMOD's
  // supernodal solve of k > 1 columns goes through OpenBLAS dgemm/dtrsm, whose packing
  // dominates for narrow panels (measured, 1 thread, continuum p = 2 pattern: 2 columns cost
  // 2.5x one column at 1,476 unknowns and 2.9x at 7,686; at 14,526 unknowns, 3.3 million
  // factor entries, memory traffic dominates and 2 columns cost 1.7x one).
  constexpr Eigen::Index kNarrowColumns = 3;
  constexpr double kInCacheFactorEntries = 2.0e6;
  if (impl_->single_ready) {
    for (Eigen::Index j = 0; j < b.cols(); ++j) {
      Eigen::VectorXd xj = bp.col(j);
      impl_->solve_permuted(xj);
      bp.col(j) = xj;
    }
  } else if (b.cols() > 1 && b.cols() <= kNarrowColumns &&
             static_cast<double>(impl_->factor.cholmod().lnz) < kInCacheFactorEntries) {
    for (Eigen::Index j = 0; j < b.cols(); ++j) {
      const Eigen::VectorXd xj = impl_->factor.solve(Eigen::VectorXd(bp.col(j)));
      bp.col(j) = xj;
    }
  } else {
    bp = impl_->factor.solve(bp).eval();
  }
  Eigen::MatrixXd x(b.rows(), b.cols());
  for (Eigen::Index k = 0; k < b.rows(); ++k) x.row(perm[k]) = bp.row(k);
  return x;
}

Eigen::VectorXd SparseCholesky::solve_factor_transpose(const Eigen::VectorXd& z) const {
  if (!impl_->ok) throw std::logic_error("sparse Cholesky: factor solve without a factorisation");
  if (z.rows() != impl_->n)
    throw std::invalid_argument("sparse Cholesky: right-hand side of " + std::to_string(z.rows()) +
                                " rows for " + std::to_string(impl_->n) + " unknowns");
  const ScopedBlasThreads blas(impl_->options.blas_threads);
  if (!impl_->ensure_double())
    throw std::runtime_error(
        "sparse Cholesky: the double factorisation of a matrix factorised in float failed");
  cholmod_factor* l = const_cast<cholmod_factor*>(impl_->factor.raw());
  if (!l->is_ll) throw std::logic_error("sparse Cholesky: factor solve needs an LL' factor");
  cholmod_common& common = impl_->factor.cholmod();
  // G = Pm' Q' L with Pm the analysis' permutation (pattern->perm) and Q CHOLMOD's own (L L' =
  // Q Ap Q', Ap the permuted matrix): G'^-1 z = Pm' Q' L'^-1 z.
  Eigen::VectorXd work = z;
  cholmod_dense b{};
  b.nrow = b.d = static_cast<size_t>(z.rows());
  b.ncol = 1;
  b.nzmax = b.nrow;
  b.x = work.data();
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* y = cholmod_solve(CHOLMOD_Lt, l, &b, &common);
  cholmod_dense* w = y ? cholmod_solve(CHOLMOD_Pt, l, y, &common) : nullptr;
  if (!w) {
    if (y) cholmod_free_dense(&y, &common);
    throw std::bad_alloc();
  }
  const double* wp = static_cast<const double*>(w->x);
  const std::vector<int>& perm = impl_->pattern->perm;
  Eigen::VectorXd x(z.rows());
  for (Eigen::Index k = 0; k < z.rows(); ++k) x(perm[k]) = wp[k];
  cholmod_free_dense(&w, &common);
  cholmod_free_dense(&y, &common);
  return x;
}

double SparseCholesky::factor_nonzeros() const {
  return impl_->analysed ? static_cast<double>(impl_->factor.cholmod().lnz) : 0.0;
}

double SparseCholesky::factor_storage() const {
  return impl_->factor.storage();
}

Eigen::Index SparseCholesky::rows() const {
  return impl_->n;
}

int SparseCholesky::ordering_block_size() const {
  return impl_->analysed ? impl_->block_size : 1;
}

int SparseCholesky::analyses() const {
  return impl_->analyses;
}

}  // namespace rbc
