// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A supernodal Cholesky factorisation A + shift I = L L' computed in single precision, on the
// supernodal structure of CHOLMOD's symbolic analysis (core/supernodal_solve.hpp's
// SinglePrecisionFactor layout), for preconditioners: at the full spectrin level the stretch's
// preconditioner factorises a 81,126-unknown Hessian (3.8e7 stored factor entries) three to
// four times per force, and the factorisation is bound by the dense kernels' arithmetic rate.
// OpenBLAS's single-precision kernels (ssyrk, sgemm, strsm, LAPACK spotrf) run at twice the
// double rate (eight instead of four lanes per AVX2 instruction) and move half the bytes.
//
// The algorithm is the left-looking supernodal one of CHOLMOD's own numeric factorisation
// (t_cholmod_super_numeric, Davis and Hager; Ng and Peyton 1993): supernode by supernode in
// order, assemble its columns of A, subtract the update of every earlier supernode that has
// rows in its columns (one ssyrk + sgemm per such descendant, scattered through a relative
// map), then spotrf on its diagonal block and strsm below it.
//
// Why hand-written: CHOLMOD 3 (Debian's SuiteSparse 5) factorises in double only (single
// precision came with CHOLMOD 5). Accuracy: the factor of a matrix within c n_row u |L||L'| of
// A (u = 2^-24), relative error of a solve ~ cond(A) 1e-7 and more where n_row is large; a
// preconditioner's quality needs no more. A matrix that is positive definite only to within
// that rounding may be found indefinite (the caller's shift keeps the project's matrices well
// clear of it: 1e-4 of the mean diagonal).
#include <cstddef>
#include <vector>

#include "core/supernodal_solve.hpp"

namespace rbc {

/// Workspace of factorize_single, sized for one supernodal structure (prepare()).
struct SupernodalFactorWorkspace {
  std::vector<int> supernode_of;  ///< n: the supernode holding each column
  std::vector<int> map;           ///< n: a row's place in the current supernode
  std::vector<int> relative;      ///< largest supernode row count: a descendant's rows' places
  std::vector<int> head, next, position;  ///< nsuper: descendant lists, next row per supernode
  std::vector<float> update;              ///< the largest descendant update
  /// Sizes the workspace for l's structure (super, row_start, rows set).
  void prepare(const SinglePrecisionFactor& l);
};

enum class SingleFactorStatus {
  factorised,
  not_positive_definite,  ///< a pivot was not positive
  /// an entry of a or the shift beyond float's range, NaN, or nonzero and below float's normal
  /// numbers; or a factor entry or an inverse pivot beyond float's range
  out_of_range,
};

/// Factorises a + shift I into l.values (and l.inverse_diagonal) in single precision. a is the
/// lower triangle of a symmetric matrix in the factor's own order (CSC: a_outer[n + 1], rows
/// a_inner sorted and >= their column, inside the supernodal structure of l), shift in the
/// units of a's entries. l's structure (n, super, row_start, value_start, rows, max_rows) must
/// be set; values is resized. not_positive_definite: a pivot was not positive, a + shift I is
/// not positive definite to within float rounding; out_of_range: the matrix or its factor does
/// not fit float's range (factorise it in double); either way l.values is then not a factor.
/// Entries below float's smallest normal number become 0. BLAS runs on the caller's BLAS
/// threads (core/blas_threads.hpp); with one, the same bits on every run.
SingleFactorStatus factorize_single(const int* a_outer, const int* a_inner, const double* a_values,
                                    double shift, SinglePrecisionFactor& l,
                                    SupernodalFactorWorkspace& work);

}  // namespace rbc
