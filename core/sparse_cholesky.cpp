#include "core/sparse_cholesky.hpp"

#include <Eigen/CholmodSupport>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>

#include "core/blas_threads.hpp"
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
};

}  // namespace detail

struct SparseCholesky::Impl {
  SparseCholeskyOptions options;
  detail::CopyableCholmod factor;
  bool analysed = false, ok = false;
  Eigen::Index n = 0;

  void configure(Eigen::Index unknowns) {
    factor.setMode(unknowns >= options.supernodal_min_unknowns ? Eigen::CholmodSupernodalLLt
                                                               : Eigen::CholmodSimplicialLLt);
    switch (options.ordering) {
      case FillOrdering::automatic:
        break;
      case FillOrdering::amd:
      case FillOrdering::metis:
      case FillOrdering::nested_dissection:
        factor.cholmod().nmethods = 1;
        factor.cholmod().method[0].ordering = options.ordering == FillOrdering::amd ? CHOLMOD_AMD
                                              : options.ordering == FillOrdering::metis
                                                  ? CHOLMOD_METIS
                                                  : CHOLMOD_NESDIS;
        break;
    }
    // Library code does not print: a failed (indefinite) trial is expected and handled by
    // the caller's shift loop.
    factor.cholmod().print = 0;
    // Supernode amalgamation (SparseCholeskyOptions::relaxed_amalgamation_below): CHOLMOD's
    // defaults, or 4 times the columns and twice the zero fraction a supernode may absorb.
    const bool relaxed = unknowns < options.relaxed_amalgamation_below;
    const size_t nrelax[3] = {4, 16, 48};
    const double zrelax[3] = {0.8, 0.1, 0.05};
    for (int i = 0; i < 3; ++i) {
      factor.cholmod().nrelax[i] = relaxed ? 4 * nrelax[i] : nrelax[i];
      factor.cholmod().zrelax[i] = relaxed ? 2 * zrelax[i] : zrelax[i];
    }
  }
};

std::unique_lock<std::mutex> lock_fill_ordering() {
  static std::mutex m;
  return std::unique_lock<std::mutex>(m);
}

SparseCholesky::SparseCholesky(const SparseCholeskyOptions& options)
    : impl_(std::make_unique<Impl>()) {
  options.validate();
  impl_->options = options;
}
SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

SparseCholesky SparseCholesky::clone() const {
  SparseCholesky c(impl_->options);
  if (impl_->analysed) {
    c.impl_->configure(impl_->n);
    c.impl_->factor.copy_factor_of(impl_->factor);
    c.impl_->analysed = true;
    c.impl_->ok = impl_->ok;
    c.impl_->n = impl_->n;
  }
  return c;
}

void SparseCholesky::analyze(const Eigen::SparseMatrix<double>& a) {
  if (a.rows() != a.cols())
    throw std::invalid_argument("sparse Cholesky: matrix must be square, got " +
                                std::to_string(a.rows()) + " x " + std::to_string(a.cols()));
  impl_->configure(a.rows());
  const auto lock = lock_fill_ordering();
  impl_->factor.analyzePattern(a);
  impl_->analysed = true;
  impl_->ok = false;
  impl_->n = a.rows();
}

bool SparseCholesky::factorize(const Eigen::SparseMatrix<double>& a) {
  if (!impl_->analysed || a.rows() != impl_->n) analyze(a);
  const ScopedBlasThreads blas(impl_->options.blas_threads);
  impl_->factor.factorize(a);
  impl_->ok = impl_->factor.info() == Eigen::Success;  // fails unless a is positive definite
  return impl_->ok;
}

bool SparseCholesky::factorised() const {
  return impl_->ok;
}

Eigen::VectorXd SparseCholesky::solve(const Eigen::VectorXd& b) const {
  if (!impl_->ok) throw std::logic_error("sparse Cholesky: solve without a factorisation");
  const ScopedBlasThreads blas(impl_->options.blas_threads);
  return impl_->factor.solve(b);
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& b) const {
  if (!impl_->ok) throw std::logic_error("sparse Cholesky: solve without a factorisation");
  const ScopedBlasThreads blas(impl_->options.blas_threads);
  // A few right-hand sides on a factor that stays in cache: one column at a time. CHOLMOD's
  // supernodal solve of k > 1 columns goes through OpenBLAS dgemm/dtrsm, whose packing
  // dominates for narrow panels (measured, 1 thread, continuum p = 2 pattern: 2 columns cost
  // 2.5x one column at 1,476 unknowns and 2.9x at 7,686; at 14,526 unknowns, 3.3 million
  // factor entries, memory traffic dominates and 2 columns cost 1.7x one).
  constexpr Eigen::Index kNarrowColumns = 3;
  constexpr double kInCacheFactorEntries = 2.0e6;
  if (b.cols() > 1 && b.cols() <= kNarrowColumns &&
      static_cast<double>(impl_->factor.cholmod().lnz) < kInCacheFactorEntries) {
    Eigen::MatrixXd x(b.rows(), b.cols());
    for (Eigen::Index j = 0; j < b.cols(); ++j) x.col(j) = impl_->factor.solve(b.col(j));
    return x;
  }
  return impl_->factor.solve(b);
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

}  // namespace rbc
