// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The project's sparse Cholesky factorisation: LL' of a symmetric positive definite sparse
// matrix by CHOLMOD (SuiteSparse), behind this small interface so that no public header
// includes CHOLMOD or Eigen's CholmodSupport (the implementation is private to
// core/sparse_cholesky.cpp). The fill-reducing ordering is analysed once per pattern
// (analyze) and reused by every numeric factorisation (factorize) of matrices with that
// pattern. Only the lower triangle of the matrix passed in is read, so full or lower block
// storage (core/block_pattern.hpp) both work. The matrix is handed to CHOLMOD already permuted
// into its order (values copied through a map made at analysis; a changed pattern is analysed
// again). Its supernodal factorisation then reads it where it lies, without the two transposed
// copies it makes of a lower triangle in the caller's order (the simplicial one still makes
// one, as before); the factor and the solutions are the same, bit for bit (README, "Sparse
// Cholesky: the permuted matrix handed over in CHOLMOD's own order"). A clone shares the
// analysed pattern and the map.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <mutex>

namespace rbc {

/// Fill-reducing ordering of the sparse Cholesky factorisation.
enum class FillOrdering {
  automatic,  ///< CHOLMOD's default: AMD, METIS tried when AMD's fill is high
  amd,        ///< approximate minimum degree
  /// METIS nested dissection; of the graph of b x b blocks where the matrix is made of them
  /// (SparseCholeskyOptions::block_ordering)
  metis,
  nested_dissection,  ///< CHOLMOD's own nested dissection (NESDIS)
};

/// Precision of SparseCholesky::solve.
enum class SolvePrecision {
  double_precision,  ///< CHOLMOD's solve on the double factor
  /// After each successful supernodal factorisation the factor is also kept rounded to float,
  /// and solve() substitutes with that copy in float (core/supernodal_solve.hpp: half the
  /// memory traffic and half the arithmetic's width): the solve of a matrix within ~1e-7
  /// relative of the one factorised, for preconditioners whose factor does not fit in cache.
  /// Costs 4 bytes per factor entry. A simplicial factor
  /// (SparseCholeskyOptions::supernodal_min_unknowns), a factor with an entry beyond float's
  /// range, and a right-hand side whose float solve is not finite (beyond float's range) are
  /// solved in double.
  single_precision,
  /// The factorisation itself in float as well (core/supernodal_factor.hpp: a left-looking
  /// supernodal factorisation on CHOLMOD's symbolic analysis with OpenBLAS's single-precision
  /// kernels, about twice the double rate), then solves as single_precision. factorize()
  /// returns false where a pivot is not positive in float: the matrix is not positive definite
  /// to within float rounding (~1e-7 relative times the fronts' sizes; for preconditioners
  /// whose matrices carry a shift well above that). A matrix or factor beyond float's range is
  /// factorised in double instead; a right-hand side whose float solve is not finite is solved
  /// with a double factorisation made then. A simplicial analysis (below
  /// supernodal_min_unknowns) and builds without SSE2 factorise and solve in double.
  single_precision_factorisation,
};

struct SparseCholeskyOptions {
  FillOrdering ordering = FillOrdering::metis;
  /// METIS orders the graph of the b x b blocks (b = 3, else 2) when the pattern is made of
  /// full blocks (a vertex's coordinates: every stored entry's whole block is stored, lower
  /// triangle), each block's unknowns then kept together in the block's place; else (or false)
  /// the graph of the unknowns. The blocks' graph has b times fewer vertices and b^2 times
  /// fewer edges than the unknowns' graph, and its order gives the same fill within 1 % (measured
  /// on the continuum p = 2 Hessian at 9,680 elements: 4.18 against 4.17 million factor
  /// entries, 1.99 against 1.98 GFlop per factorisation; README, "Sparse Cholesky: the ordering
  /// of the vertex blocks").
  bool block_ordering = true;
  /// CHOLMOD's simplicial LL' (no BLAS) below this many unknowns, supernodal LL' (BLAS
  /// dgemm) from it on; 0 = always supernodal (measured faster from ~750 unknowns on, once
  /// BLAS runs on one thread: note_speed.md).
  int supernodal_min_unknowns = 0;
  /// Below this many unknowns a supernodal factorisation relaxes CHOLMOD's supernode
  /// amalgamation: nrelax 16/64/192 columns instead of 4/16/48, and zrelax 1.6/0.2/0.1 instead
  /// of 0.8/0.1/0.05. (A zero fraction above 1 merges every supernode of up to 16 columns.)
  /// Supernodes become fewer and wider, so CHOLMOD makes fewer and larger BLAS calls, at the
  /// cost of some extra fill. Measured at one thread (README, "Sparse Cholesky: supernode
  /// amalgamation"):
  ///   - one stability check, mirror-planes mesh, 5,120 elements (seven 960-unknown sectors):
  ///     15.3-15.7 -> 13.0-13.2 ms;
  ///   - the 7,686-unknown full problem at 5,120 elements: 10 % slower, hence the bound;
  ///   - 3,600-3,843 unknowns: no change.
  /// 0 = CHOLMOD's defaults always.
  int relaxed_amalgamation_below = 4000;
  /// BLAS (OpenBLAS and OpenMP) threads of the factorisation and solves
  /// (core/blas_threads.hpp); 0 = the caller's. One keeps the rounding independent of the
  /// core count and avoids thread wake-ups on CHOLMOD's many small BLAS calls.
  int blas_threads = 1;
  SolvePrecision solve_precision = SolvePrecision::double_precision;
  /// Throws std::invalid_argument naming the quantity: thresholds >= 0, threads in [0, 1024].
  void validate() const;
};

/// Held around every CHOLMOD symbolic analysis in the process (SparseCholesky::analyze, the
/// project's one CHOLMOD wrapper). METIS, CHOLMOD's nested-dissection ordering, draws
/// from one process-wide random state that each call re-seeds: two analyses running at once
/// interleave their draws, so the ordering, and with it the factor's rounding, depended on
/// thread timing (measured: `rbc infer` with 2 threads gave posteriors differing at 1e-13 run
/// to run). Analyses are rare (once per pattern and solver), so serialising them costs
/// nothing measurable. The one process-wide object of the libraries: it guards a library
/// that has process-wide state.
[[nodiscard]] std::unique_lock<std::mutex> lock_fill_ordering();

class SparseCholesky {
 public:
  explicit SparseCholesky(const SparseCholeskyOptions& options = {});
  ~SparseCholesky();
  SparseCholesky(SparseCholesky&&) noexcept;
  SparseCholesky& operator=(SparseCholesky&&) noexcept;
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;
  /// A deep copy of the analysis and the factor (the original may then be refactorised while
  /// the copy is kept, e.g. one factorisation per force of a sweep).
  SparseCholesky clone() const;

  /// Symbolic analysis (ordering, elimination tree) of a's pattern (compressed, square).
  void analyze(const Eigen::SparseMatrix<double>& a);
  /// Numeric factorisation of a + diagonal_shift I (analyses first if a's pattern is not the one
  /// analysed). The shift is added to each diagonal entry as the entry is assembled, as
  /// adding it to a's diagonal would, without a copy of a. Returns false if the shifted matrix
  /// is not numerically positive definite (or has a non-finite entry in its lower triangle); the
  /// factor is then invalid. A non-finite shift:
  /// std::invalid_argument.
  bool factorize(const Eigen::SparseMatrix<double>& a, double diagonal_shift = 0.0);
  /// True after a successful factorize().
  bool factorised() const;
  /// Solves a x = b with the last successful factorisation (in the options' precision). Not
  /// for concurrent calls on one object: CHOLMOD's solve writes its workspace, and under
  /// single_precision_factorisation a right-hand side whose float solve overflows makes the
  /// double factorisation then (clones are independent).
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const;
  /// With the factorised matrix written A = G G' (G = P' L, L CHOLMOD's lower factor and P
  /// every permutation of the analysis), returns G'^-1 z. For z of independent standard normal
  /// entries the result is a draw of N(0, A^-1), and A times it a draw of N(0, A): the momenta
  /// of Hamiltonian Monte Carlo with mass matrix A (discrete/hmc_sampler.hpp). Always in double
  /// precision (a double factorisation is made first under single_precision_factorisation).
  /// std::logic_error without a factorisation or for an LDL' factor (a simplicial analysis).
  Eigen::VectorXd solve_factor_transpose(const Eigen::VectorXd& z) const;
  /// Nonzeros of the factor L (0 before the first factorisation).
  double factor_nonzeros() const;
  /// Entries stored for L, the explicit zeros of amalgamated supernodes included (0 before the
  /// first analysis).
  double factor_storage() const;
  Eigen::Index rows() const;
  /// The block size b whose graph the last analysis ordered (SparseCholeskyOptions::
  /// block_ordering): 3 or 2, or 1 for the unknowns' own graph (and before an analysis).
  int ordering_block_size() const;
  /// Symbolic analyses made so far: analyze() calls and the analyses factorize() makes on a
  /// pattern other than the one analysed (a clone starts with its original's count).
  int analyses() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rbc
