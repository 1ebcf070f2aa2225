// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A supernodal Cholesky factor L (A = L L') kept in single precision, and its forward and back
// substitution in single precision: the solves of a preconditioner whose factor does not fit in
// cache. Such a solve reads every stored entry of L twice (L y = b, then L' x = y). At the full
// spectrin level (3.8e7 stored entries, 307 MB in double) one application of the stretch's
// preconditioner took 42-47 ms with CHOLMOD's double solve and takes 25-30 ms with this one
// (`rbc bench stretch --benchmark_filter=preconditioner_apply`; the solve alone 22 ms). Solving
// in float is what gains: with the factor in float but the arithmetic in double, the widening
// and the two-lane double arithmetic kept the solve at 34 ms. The result is the exact solve of a
// matrix within a few float roundings of A (backward error ~ n_row u |L||L'|, u = 2^-24), so its
// relative error is ~ cond(A) 1e-7: a preconditioner's quality is unchanged, but this is not an
// exact solve.
//
// Why hand-written: CHOLMOD 3 (Debian's SuiteSparse 5) factorises and solves in double only
// (single precision came with CHOLMOD 5), and a preconditioner only needs the solve. The
// layout is CHOLMOD's (cholmod_factor, is_super): supernode k holds columns
// super[k] .. super[k+1]-1, its rows rows[row_start[k]] .. rows[row_start[k+1]-1] (the first
// ones being its own columns), and a dense column-major block of those rows by its columns at
// values[value_start[k]] (leading dimension = its row count; the upper part of the diagonal
// block is not read).
#include <cstdint>
#include <vector>

namespace rbc {

struct SinglePrecisionFactor {
  int n = 0;                              ///< order of L
  std::vector<int> super;                 ///< nsuper + 1 first columns
  std::vector<int> row_start;             ///< nsuper + 1 offsets into rows
  std::vector<std::int64_t> value_start;  ///< nsuper + 1 offsets into values
  std::vector<int> rows;                  ///< row indices of each supernode
  std::vector<float> values;              ///< the supernodes' dense blocks, rounded to float
  std::vector<float> inverse_diagonal;    ///< 1 / L(j, j), computed in double and rounded
  int max_rows = 0;                       ///< largest row count of a supernode
  int supernodes() const { return static_cast<int>(super.size()) - 1; }
};

/// Whether this build has the solve below (x86-64: SSE2); SparseCholesky solves in double
/// otherwise.
bool single_precision_solves_available();

/// Solves L L' x = b in place (x holds b on entry, n entries, in the factor's own order: the
/// caller applies the fill-reducing permutation), b rounded to float, both substitutions in
/// float, supernode by supernode, in a fixed order: the same bits on every run and on every
/// x86-64 machine (SSE2 throughout, in both clones of RBC_HOT_CLONES).
void solve_in_place(const SinglePrecisionFactor& l, double* x);

}  // namespace rbc
