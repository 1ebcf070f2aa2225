// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/supernodal_factor.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

// Fortran BLAS and LAPACK (OpenBLAS on the project's machines), with gfortran's hidden lengths
// of the character arguments.
extern "C" {
void ssyrk_(const char* uplo, const char* trans, const int* n, const int* k, const float* alpha,
            const float* a, const int* lda, const float* beta, float* c, const int* ldc,
            std::size_t uplo_len, std::size_t trans_len);
void sgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
            const float* alpha, const float* a, const int* lda, const float* b, const int* ldb,
            const float* beta, float* c, const int* ldc, std::size_t transa_len,
            std::size_t transb_len);
void strsm_(const char* side, const char* uplo, const char* transa, const char* diag, const int* m,
            const int* n, const float* alpha, const float* a, const int* lda, float* b,
            const int* ldb, std::size_t side_len, std::size_t uplo_len, std::size_t transa_len,
            std::size_t diag_len);
void spotrf_(const char* uplo, const int* n, float* a, const int* lda, int* info,
             std::size_t uplo_len);
}

namespace rbc {

void SupernodalFactorWorkspace::prepare(const SinglePrecisionFactor& l) {
  const int nsuper = l.supernodes();
  supernode_of.assign(static_cast<std::size_t>(l.n), 0);
  for (int s = 0; s < nsuper; ++s)
    std::fill(supernode_of.begin() + l.super[static_cast<std::size_t>(s)],
              supernode_of.begin() + l.super[static_cast<std::size_t>(s) + 1], s);
  map.assign(static_cast<std::size_t>(l.n), 0);
  relative.assign(static_cast<std::size_t>(std::max(l.max_rows, 1)), 0);
  head.assign(static_cast<std::size_t>(nsuper), -1);
  next.assign(static_cast<std::size_t>(nsuper), -1);
  position.assign(static_cast<std::size_t>(nsuper), 0);
  // The largest update: a supernode's rows below its columns fall into later supernodes in
  // runs; the run in supernode s (ndrow1 rows) with all the rows after it (ndrow2) updates s.
  std::size_t largest = 1;
  for (int d = 0; d < nsuper; ++d) {
    const int begin = l.row_start[static_cast<std::size_t>(d)];
    const int end = l.row_start[static_cast<std::size_t>(d) + 1];
    int p =
        begin + (l.super[static_cast<std::size_t>(d) + 1] - l.super[static_cast<std::size_t>(d)]);
    while (p < end) {
      const int s = supernode_of[static_cast<std::size_t>(l.rows[static_cast<std::size_t>(p)])];
      const int stop = l.super[static_cast<std::size_t>(s) + 1];
      int q = p;
      while (q < end && l.rows[static_cast<std::size_t>(q)] < stop) ++q;
      largest =
          std::max(largest, static_cast<std::size_t>(q - p) * static_cast<std::size_t>(end - p));
      p = q;
    }
  }
  update.assign(largest, 0.0f);
}

SingleFactorStatus factorize_single(const int* a_outer, const int* a_inner, const double* a_values,
                                    double shift, SinglePrecisionFactor& l,
                                    SupernodalFactorWorkspace& w) {
  const int nsuper = l.supernodes();
  // Entries beyond float's range, NaN, or nonzero below its normal numbers (a subnormal keeps
  // fewer bits): the matrix does not fit float.
  constexpr double kLargest = std::numeric_limits<float>::max();
  constexpr double kNormal = std::numeric_limits<float>::min();
  auto fits = [&](double v) {
    const double m = std::abs(v);
    return m <= kLargest && (m >= kNormal || m == 0.0);
  };
  for (int p = 0; p < a_outer[l.n]; ++p)
    if (!fits(a_values[p])) return SingleFactorStatus::out_of_range;
  if (!fits(shift)) return SingleFactorStatus::out_of_range;
  if (w.head.size() != static_cast<std::size_t>(nsuper) ||
      w.map.size() != static_cast<std::size_t>(l.n))
    w.prepare(l);
  std::fill(w.head.begin(), w.head.end(), -1);
  l.values.resize(static_cast<std::size_t>(l.value_start[static_cast<std::size_t>(nsuper)]));
  l.inverse_diagonal.resize(static_cast<std::size_t>(l.n));
  const int* rows = l.rows.data();
  const float one = 1.0f, zero = 0.0f;
  constexpr float kSmallest = std::numeric_limits<float>::min();
  for (int s = 0; s < nsuper; ++s) {
    const std::size_t su = static_cast<std::size_t>(s);
    const int k1 = l.super[su], k2 = l.super[su + 1], nscol = k2 - k1;
    const int psi = l.row_start[su], nsrow = l.row_start[su + 1] - psi;
    float* ls = l.values.data() + l.value_start[su];
    for (int i = 0; i < nsrow; ++i) w.map[static_cast<std::size_t>(rows[psi + i])] = i;
    // 1. The supernode's columns of a, + shift on the diagonal (also where a stores no diagonal
    // entry, as adding the shift to a's diagonal would; a stored one is summed in double first).
    std::fill(ls, ls + static_cast<std::ptrdiff_t>(nsrow) * nscol, 0.0f);
    for (int j = 0; j < nscol; ++j)
      ls[static_cast<std::ptrdiff_t>(j) * nsrow + j] = static_cast<float>(shift);
    for (int k = k1; k < k2; ++k) {
      float* column = ls + static_cast<std::ptrdiff_t>(k - k1) * nsrow;
      for (int p = a_outer[k]; p < a_outer[k + 1]; ++p) {
        const int i = a_inner[p];
        column[w.map[static_cast<std::size_t>(i)]] =
            static_cast<float>(i == k ? a_values[p] + shift : a_values[p]);
      }
    }
    // 2. Minus the update of each descendant d with rows in columns k1 .. k2 - 1.
    for (int d = w.head[su]; d != -1;) {
      const std::size_t du = static_cast<std::size_t>(d);
      const int next_d = w.next[du];
      const int pdi = l.row_start[du], ndrow = l.row_start[du + 1] - pdi;
      const int ndcol = l.super[du + 1] - l.super[du];
      const int first = w.position[du];  // d's first row >= k1 (its place in d's rows)
      int stop = first;
      while (stop < ndrow && rows[pdi + stop] < k2) ++stop;
      const int ndrow1 = stop - first, ndrow2 = ndrow - first, ndrow3 = ndrow2 - ndrow1;
      const float* ld = l.values.data() + l.value_start[du] + first;
      float* c = w.update.data();
      // C = L_d(first:, :) L_d(first:stop, :)': lower triangle of the top, then the rest.
      ssyrk_("L", "N", &ndrow1, &ndcol, &one, ld, &ndrow, &zero, c, &ndrow2, 1, 1);
      if (ndrow3 > 0)
        sgemm_("N", "T", &ndrow3, &ndrow1, &ndcol, &one, ld + ndrow1, &ndrow, ld, &ndrow, &zero,
               c + ndrow1, &ndrow2, 1, 1);
      for (int i = 0; i < ndrow2; ++i)
        w.relative[static_cast<std::size_t>(i)] =
            w.map[static_cast<std::size_t>(rows[pdi + first + i])];
      for (int j = 0; j < ndrow1; ++j) {
        float* target =
            ls + static_cast<std::ptrdiff_t>(w.relative[static_cast<std::size_t>(j)]) * nsrow;
        const float* cj = c + static_cast<std::ptrdiff_t>(j) * ndrow2;
        for (int i = j; i < ndrow2; ++i) target[w.relative[static_cast<std::size_t>(i)]] -= cj[i];
      }
      // d's next rows (if any) update a later supernode.
      w.position[du] = stop;
      if (ndrow3 > 0) {
        const std::size_t t =
            static_cast<std::size_t>(w.supernode_of[static_cast<std::size_t>(rows[pdi + stop])]);
        w.next[du] = w.head[t];
        w.head[t] = d;
      }
      d = next_d;
    }
    w.head[su] = -1;
    // 3. The diagonal block, then the rows below it.
    int info = 0;
    spotrf_("L", &nscol, ls, &nsrow, &info, 1);
    if (info != 0) return SingleFactorStatus::not_positive_definite;
    if (nsrow > nscol) {
      const int below = nsrow - nscol;
      strsm_("R", "L", "T", "N", &below, &nscol, &one, ls, &nsrow, ls + nscol, &nsrow, 1, 1, 1, 1);
    }
    for (int j = 0; j < nscol; ++j) {
      const float pivot = ls[static_cast<std::ptrdiff_t>(j) * nsrow + j];
      const float inverse = static_cast<float>(1.0 / static_cast<double>(pivot));
      if (!(pivot > 0.0f)) return SingleFactorStatus::not_positive_definite;
      if (!std::isfinite(pivot) || !std::isfinite(inverse) || inverse < kSmallest)
        return SingleFactorStatus::out_of_range;
      l.inverse_diagonal[static_cast<std::size_t>(k1 + j)] = inverse;
    }
    // Subnormal entries (a microcode assist per use in the solves) become 0; a non-finite one
    // means the matrix is beyond float's range.
    for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(nsrow) * nscol; ++k) {
      if (!std::isfinite(ls[k])) return SingleFactorStatus::out_of_range;
      if (std::abs(ls[k]) < kSmallest) ls[k] = 0.0f;
    }
    // s updates the supernode holding its first row below its columns.
    w.position[su] = nscol;
    if (nsrow > nscol) {
      const std::size_t t =
          static_cast<std::size_t>(w.supernode_of[static_cast<std::size_t>(rows[psi + nscol])]);
      w.next[su] = w.head[t];
      w.head[t] = s;
    }
  }
  return SingleFactorStatus::factorised;
}

}  // namespace rbc
