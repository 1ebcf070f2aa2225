// SPDX-License-Identifier: GPL-3.0-or-later
// The project's shifted Newton (core/shifted_newton.hpp) and sparse Cholesky
// (core/sparse_cholesky.hpp) against closed forms: the minimiser of a separable quartic, the
// closest point of a sphere (Lagrange multiplier known), a double well entered where the
// Hessian is negative (Levenberg shift), a Hessian no shift within the budget repairs
// (factorisation failure reported as such), chord steps across calls, and analyses on two
// threads at once (bit-identical to serial: METIS is not reentrant).
#include <SuiteSparse_config.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/shifted_newton.hpp"
#include "core/sparse_cholesky.hpp"

namespace rbc {
namespace {

/// Tridiagonal pattern (explicit zeros off the diagonal) of size n with diagonal d.
Eigen::SparseMatrix<double> tridiagonal(const Eigen::VectorXd& d, double off = 0.0) {
  const Eigen::Index n = d.size();
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index i = 0; i < n; ++i) {
    t.emplace_back(i, i, d(i));
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, off);
      t.emplace_back(i + 1, i, off);
    }
  }
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  m.makeCompressed();
  return m;
}

/// The 5-point stencil of an m x m grid with `diagonal` on the diagonal and -1 to each
/// neighbour, lower triangle (as the solvers pass it).
Eigen::SparseMatrix<double> grid_lower(int m, double diagonal) {
  const int n = m * m;
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      const int k = i * m + j;
      t.emplace_back(k, k, diagonal);
      if (i + 1 < m) t.emplace_back(k + m, k, -1.0);
      if (j + 1 < m) t.emplace_back(k + 1, k, -1.0);
    }
  Eigen::SparseMatrix<double> a(n, n);
  a.setFromTriplets(t.begin(), t.end());
  a.makeCompressed();
  return a;
}

TEST(SparseCholesky, SolvesAPositiveDefiniteSystemAndRefusesAnIndefiniteOne) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 200;
  Eigen::VectorXd d(n), b(n);
  for (int i = 0; i < n; ++i) d(i) = 3.0 + u(rng), b(i) = u(rng);
  const Eigen::SparseMatrix<double> a = tridiagonal(d, -1.0);  // diagonally dominant: SPD
  for (const int threshold : {0, 1 << 30}) {                   // supernodal, simplicial
    SparseCholeskyOptions o;
    o.supernodal_min_unknowns = threshold;
    SparseCholesky c(o);
    EXPECT_THROW(c.solve(b), std::logic_error);
    ASSERT_TRUE(c.factorize(a));
    const Eigen::VectorXd x = c.solve(b);
    EXPECT_LT((a * x - b).norm(), 1e-12 * b.norm());
    Eigen::SparseMatrix<double> bad = a;
    bad.coeffRef(n / 2, n / 2) = -5.0;
    EXPECT_FALSE(c.factorize(bad));
    EXPECT_FALSE(c.factorised());
  }
  SparseCholeskyOptions o;
  o.blas_threads = -1;
  EXPECT_THROW(SparseCholesky{o}, std::invalid_argument);
}

TEST(SparseCholesky, CountsEveryAnalysisIncludingTheOnesAFactorisationMakes) {
  // The count the preconditioners report (NewtonPreconditioner::Statistics::analyses): an
  // explicit analysis, none for a refactorisation of the same pattern, one for a factorisation
  // of another pattern; a clone carries the count.
  const Eigen::SparseMatrix<double> a = grid_lower(8, 4.1), b = grid_lower(9, 4.1);
  SparseCholesky c;
  EXPECT_EQ(c.analyses(), 0);
  c.analyze(a);
  EXPECT_EQ(c.analyses(), 1);
  ASSERT_TRUE(c.factorize(a));
  ASSERT_TRUE(c.factorize(a, 0.5));
  EXPECT_EQ(c.analyses(), 1);
  ASSERT_TRUE(c.factorize(b));
  EXPECT_EQ(c.analyses(), 2);
  EXPECT_EQ(c.rows(), 81);
  EXPECT_EQ(c.clone().analyses(), 2);
  SparseCholesky fresh;
  ASSERT_TRUE(fresh.factorize(a));  // analysed by the factorisation
  EXPECT_EQ(fresh.analyses(), 1);
}

TEST(SparseCholesky, RelaxedAmalgamationSolvesTheSameSystemWithWiderSupernodes) {
  // A 2-D grid (5-point stencil plus a diagonal shift: SPD) of 900 unknowns, METIS-ordered: its
  // separators give supernodes a few columns wide, which the relaxed amalgamation merges at the
  // price of explicit zeros in L. Same solution to rounding; more stored entries.
  const int m = 30, n = m * m;
  const Eigen::SparseMatrix<double> a = grid_lower(m, 4.1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd b(n);
  for (auto& v : b) v = u(rng);
  double nnz[2];
  Eigen::VectorXd x[2];
  for (int relaxed : {0, 1}) {
    SparseCholeskyOptions o;
    o.relaxed_amalgamation_below = relaxed ? n + 1 : 0;
    SparseCholesky c(o);
    ASSERT_TRUE(c.factorize(a));
    x[relaxed] = c.solve(b);
    nnz[relaxed] = c.factor_storage();
  }
  const Eigen::SparseMatrix<double> full =
      a.selfadjointView<Eigen::Lower>() *
      Eigen::SparseMatrix<double>(Eigen::VectorXd::Ones(n).asDiagonal());
  for (int r : {0, 1}) EXPECT_LT((full * x[r] - b).norm(), 1e-12 * b.norm());
  EXPECT_LT((x[1] - x[0]).norm(), 1e-13 * x[0].norm());
  EXPECT_GT(nnz[1], nnz[0]);
  SparseCholeskyOptions bad;
  bad.relaxed_amalgamation_below = -1;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

TEST(SparseCholesky, ShiftedFactorisationFindsTheClosedFormDefiniteBoundary) {
  // The 5-point Laplacian of an m x m grid (Dirichlet) has the smallest eigenvalue
  // lambda_min = 4 - 4 cos(pi / (m + 1)); a = Laplacian - I, lower triangle as the solvers pass
  // it. a + s I is positive definite exactly for s > 1 - lambda_min. The shift is CHOLMOD's
  // (added as the diagonal is assembled): the factor of a + s I given as a matrix, bit for bit.
  const int m = 30, n = m * m;
  const Eigen::SparseMatrix<double> a = grid_lower(m, 4.0 - 1.0);
  const double boundary = 1.0 - (4.0 - 4.0 * std::cos(M_PI / (m + 1)));
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd b(n);
  for (auto& v : b) v = u(rng);
  for (const int threshold : {0, 1 << 30}) {  // supernodal, simplicial
    SparseCholeskyOptions o;
    o.supernodal_min_unknowns = threshold;
    SparseCholesky c(o);
    EXPECT_FALSE(c.factorize(a));                   // indefinite unshifted
    EXPECT_FALSE(c.factorize(a, boundary - 1e-6));  // just below the boundary
    ASSERT_TRUE(c.factorize(a, boundary + 1e-6));   // just above it
    const double s = boundary + 0.5;
    ASSERT_TRUE(c.factorize(a, s));
    const Eigen::VectorXd x = c.solve(b);
    Eigen::SparseMatrix<double> shifted = a;
    for (int k = 0; k < n; ++k) shifted.coeffRef(k, k) += s;
    SparseCholesky explicit_shift(o);
    ASSERT_TRUE(explicit_shift.factorize(shifted));
    EXPECT_EQ((explicit_shift.solve(b) - x).cwiseAbs().maxCoeff(), 0.0);
    const Eigen::SparseMatrix<double> full =
        Eigen::SparseMatrix<double>(shifted.selfadjointView<Eigen::Lower>());
    EXPECT_LT((full * x - b).norm(), 1e-12 * b.norm());
    // An uncompressed matrix (Eigen's insert mode) is factorised as its compressed copy.
    Eigen::SparseMatrix<double> loose = shifted;
    loose.uncompress();
    SparseCholesky from_loose(o);
    ASSERT_TRUE(from_loose.factorize(loose));
    EXPECT_EQ((from_loose.solve(b) - x).cwiseAbs().maxCoeff(), 0.0);
  }
}

TEST(SparseCholesky, AChangedPatternOfTheSameSizeIsAnalysedAgain) {
  // The same size and nonzero count, another pattern: one coupling (k, k+1) moved to (k, k+2).
  // Factorised on the first pattern's analysis, the values would land in the wrong places.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 120, k = 60;
  Eigen::VectorXd d(n), rhs(n);
  for (int i = 0; i < n; ++i) d(i) = 3.0 + u(rng), rhs(i) = u(rng);
  const Eigen::SparseMatrix<double> a = tridiagonal(d, -1.0);
  std::vector<Eigen::Triplet<double>> t;
  for (int j = 0; j < a.outerSize(); ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(a, j); it; ++it)
      if (!((it.row() == k && it.col() == k + 1) || (it.row() == k + 1 && it.col() == k)))
        t.emplace_back(static_cast<int>(it.row()), static_cast<int>(it.col()), it.value());
  t.emplace_back(k, k + 2, -0.5);
  t.emplace_back(k + 2, k, -0.5);
  Eigen::SparseMatrix<double> b(n, n);
  b.setFromTriplets(t.begin(), t.end());
  b.makeCompressed();
  ASSERT_EQ(b.nonZeros(), a.nonZeros());
  SparseCholesky c;
  ASSERT_TRUE(c.factorize(a));
  EXPECT_LT((a * c.solve(rhs) - rhs).norm(), 1e-12 * rhs.norm());
  ASSERT_TRUE(c.factorize(b));
  EXPECT_LT((b * c.solve(rhs) - rhs).norm(), 1e-12 * rhs.norm());
}

TEST(SparseCholesky, VertexBlocksAreOrderedAsBlocksWithTheSameFill) {
  // The grid Laplacian (+ 0.1 I) coupled through an SPD b x b block, A (x) B: every vertex of the
  // grid carries b unknowns, every coupling a full block, as a mesh's position Hessian. METIS
  // orders the grid (b^2 times fewer edges) and each vertex's unknowns stay together: the same
  // solution, and fill within a few per cent of the unknowns' own order.
  const int m = 24;
  const Eigen::SparseMatrix<double> grid =
      Eigen::SparseMatrix<double>(grid_lower(m, 4.1).selfadjointView<Eigen::Lower>());
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const int b : {3, 2}) {
    Eigen::MatrixXd g(b, b);
    for (auto& v : g.reshaped()) v = u(rng);
    const Eigen::MatrixXd block = g * g.transpose() + b * Eigen::MatrixXd::Identity(b, b);
    std::vector<Eigen::Triplet<double>> t;
    for (int j = 0; j < grid.outerSize(); ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(grid, j); it; ++it)
        for (int r = 0; r < b; ++r)
          for (int c = 0; c < b; ++c) {
            const int row = b * static_cast<int>(it.row()) + r, col = b * j + c;
            if (row >= col) t.emplace_back(row, col, it.value() * block(r, c));
          }
    const int n = b * m * m;
    Eigen::SparseMatrix<double> a(n, n);
    a.setFromTriplets(t.begin(), t.end());
    a.makeCompressed();
    Eigen::VectorXd rhs(n);
    for (auto& v : rhs) v = u(rng);
    const Eigen::SparseMatrix<double> full =
        Eigen::SparseMatrix<double>(a.selfadjointView<Eigen::Lower>());
    double nnz[2];
    Eigen::VectorXd x[2];
    for (const bool blocks : {true, false}) {
      SparseCholeskyOptions o;
      o.block_ordering = blocks;
      SparseCholesky c(o);
      EXPECT_EQ(c.ordering_block_size(), 1);  // nothing analysed yet
      ASSERT_TRUE(c.factorize(a));
      EXPECT_EQ(c.ordering_block_size(), blocks ? b : 1);
      EXPECT_EQ(c.clone().ordering_block_size(), blocks ? b : 1);
      x[blocks] = c.solve(rhs);
      nnz[blocks] = c.factor_nonzeros();
      EXPECT_LT((full * x[blocks] - rhs).norm(), 1e-12 * rhs.norm());
    }
    EXPECT_LT((x[1] - x[0]).norm(), 1e-12 * x[0].norm());
    EXPECT_LT(std::abs(nnz[1] / nnz[0] - 1.0), 0.05) << nnz[1] << " against " << nnz[0];
    // One entry of an off-diagonal block dropped: no longer made of full blocks.
    std::vector<Eigen::Triplet<double>> broken;
    bool dropped = false;
    for (const auto& e : t)
      if (!dropped && e.row() / b != e.col() / b)
        dropped = true;
      else
        broken.push_back(e);
    Eigen::SparseMatrix<double> ab(n, n);
    ab.setFromTriplets(broken.begin(), broken.end());
    ab.makeCompressed();
    SparseCholesky c;
    ASSERT_TRUE(c.factorize(ab));
    EXPECT_EQ(c.ordering_block_size(), 1);
    // Other orderings order the unknowns.
    SparseCholeskyOptions amd;
    amd.ordering = FillOrdering::amd;
    SparseCholesky by_amd(amd);
    ASSERT_TRUE(by_amd.factorize(a));
    EXPECT_EQ(by_amd.ordering_block_size(), 1);
  }
}

TEST(SparseCholesky, CholmodsLargeBlocksLieOnAlignedMappingsAndKeepTheirContents) {
  // SparseCholesky gives CHOLMOD an allocator that maps blocks of 4 MiB and more on their own
  // 2 MiB-aligned mappings (huge pages advised): malloc, calloc, realloc across the threshold
  // both ways and free must keep the C contracts CHOLMOD relies on.
  const SparseCholesky installs;
  constexpr size_t kMiB = size_t{1} << 20;
  auto aligned = [](const void* p) {
    return reinterpret_cast<std::uintptr_t>(p) % (2 * kMiB) == 0;
  };
  auto* big = static_cast<unsigned char*>(SuiteSparse_malloc(5 * kMiB, 1));
  ASSERT_NE(big, nullptr);
  EXPECT_TRUE(aligned(big));
  for (size_t k = 0; k < 5 * kMiB; ++k) big[k] = static_cast<unsigned char>(k * 7 + 3);
  int ok = 0;
  auto* bigger = static_cast<unsigned char*>(SuiteSparse_realloc(9 * kMiB, 5 * kMiB, 1, big, &ok));
  ASSERT_TRUE(ok);
  EXPECT_TRUE(aligned(bigger));
  bool same = true;
  for (size_t k = 0; k < 5 * kMiB; ++k)
    same = same && bigger[k] == static_cast<unsigned char>(k * 7 + 3);
  EXPECT_TRUE(same);
  // Within the same 2 MiB-rounded mapping (9 -> 9.5 -> 8.5 MiB on 10 MiB): the same block,
  // its contents kept; across the rounding (-> 11 MiB) a new mapping.
  auto* resized = static_cast<unsigned char*>(
      SuiteSparse_realloc(9 * kMiB + kMiB / 2, 9 * kMiB, 1, bigger, &ok));
  ASSERT_TRUE(ok);
  EXPECT_EQ(resized, bigger);
  resized = static_cast<unsigned char*>(
      SuiteSparse_realloc(8 * kMiB + kMiB / 2, 9 * kMiB + kMiB / 2, 1, resized, &ok));
  ASSERT_TRUE(ok);
  EXPECT_EQ(resized, bigger);
  std::fill(resized + 5 * kMiB, resized + 8 * kMiB + kMiB / 2, static_cast<unsigned char>(0x5A));
  bigger = static_cast<unsigned char*>(
      SuiteSparse_realloc(11 * kMiB, 8 * kMiB + kMiB / 2, 1, resized, &ok));
  ASSERT_TRUE(ok);
  EXPECT_TRUE(aligned(bigger));
  for (size_t k = 0; k < 5 * kMiB; ++k)
    same = same && bigger[k] == static_cast<unsigned char>(k * 7 + 3);
  for (size_t k = 5 * kMiB; k < 8 * kMiB + kMiB / 2; ++k) same = same && bigger[k] == 0x5A;
  EXPECT_TRUE(same);
  auto* small = static_cast<unsigned char*>(SuiteSparse_realloc(1000, 11 * kMiB, 1, bigger, &ok));
  ASSERT_TRUE(ok);
  for (size_t k = 0; k < 1000; ++k)
    same = same && small[k] == static_cast<unsigned char>(k * 7 + 3);
  EXPECT_TRUE(same);
  auto* grown = static_cast<unsigned char*>(SuiteSparse_realloc(6 * kMiB, 1000, 1, small, &ok));
  ASSERT_TRUE(ok);
  EXPECT_TRUE(aligned(grown));
  for (size_t k = 0; k < 1000; ++k)
    same = same && grown[k] == static_cast<unsigned char>(k * 7 + 3);
  EXPECT_TRUE(same);
  SuiteSparse_free(grown);
  auto* zeros = static_cast<double*>(SuiteSparse_calloc(kMiB, sizeof(double)));  // 8 MiB
  ASSERT_NE(zeros, nullptr);
  EXPECT_TRUE(aligned(zeros));
  EXPECT_EQ(*std::max_element(zeros, zeros + kMiB), 0.0);
  SuiteSparse_free(zeros);
  SuiteSparse_free(SuiteSparse_calloc(10, 10));  // small blocks: malloc's
  // A freed mapping may be handed out again (kept for reuse): calloc's must still read 0, and
  // a block freed while another of its size is live is a different one.
  for (int round = 0; round < 3; ++round) {
    auto* dirty = static_cast<unsigned char*>(SuiteSparse_malloc(6 * kMiB, 1));
    ASSERT_NE(dirty, nullptr);
    EXPECT_TRUE(aligned(dirty));
    std::fill(dirty, dirty + 6 * kMiB, static_cast<unsigned char>(0xAB));
    auto* other = static_cast<unsigned char*>(SuiteSparse_malloc(6 * kMiB, 1));
    ASSERT_NE(other, nullptr);
    EXPECT_NE(other, dirty);
    SuiteSparse_free(dirty);
    auto* clean = static_cast<unsigned char*>(SuiteSparse_calloc(6 * kMiB, 1));
    ASSERT_NE(clean, nullptr);
    EXPECT_TRUE(aligned(clean));
    EXPECT_EQ(*std::max_element(clean, clean + 6 * kMiB), 0) << round;
    SuiteSparse_free(clean);
    SuiteSparse_free(other);
  }
  // A size within two pages of SIZE_MAX is refused, not wrapped to an empty mapping.
  EXPECT_EQ(SuiteSparse_malloc(std::numeric_limits<size_t>::max() - 8, 1), nullptr);
  EXPECT_EQ(SuiteSparse_malloc((size_t{1} << 61) - 1, 8), nullptr);
  // A factor of more than 4 MiB (the grid Laplacian of 22,500 unknowns) on such a mapping.
  const int m = 150, n = m * m;
  const Eigen::SparseMatrix<double> a = grid_lower(m, 4.1);
  SparseCholesky c;
  ASSERT_TRUE(c.factorize(a));
  ASSERT_GT(c.factor_storage() * sizeof(double), 4.0 * kMiB);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd b(n);
  for (auto& v : b) v = u(rng);
  const Eigen::SparseMatrix<double> full =
      Eigen::SparseMatrix<double>(a.selfadjointView<Eigen::Lower>());
  EXPECT_LT((full * c.solve(b) - b).norm(), 1e-12 * b.norm());
}

TEST(SparseCholesky, CloneKeepsItsFactorWhileTheOriginalIsRefactorised) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 300;
  Eigen::VectorXd d(n), b(n);
  for (int i = 0; i < n; ++i) d(i) = 3.0 + u(rng), b(i) = u(rng);
  const Eigen::SparseMatrix<double> a = tridiagonal(d, -1.0);
  const Eigen::SparseMatrix<double> a2 = tridiagonal(d + Eigen::VectorXd::Constant(n, 2.0), 0.5);
  for (const int threshold : {0, 1 << 30}) {  // supernodal, simplicial
    SparseCholeskyOptions o;
    o.supernodal_min_unknowns = threshold;
    SparseCholesky c(o);
    EXPECT_FALSE(c.clone().factorised());  // a clone of nothing is empty
    ASSERT_TRUE(c.factorize(a));
    const Eigen::VectorXd x = c.solve(b);
    SparseCholesky kept = c.clone();
    ASSERT_TRUE(kept.factorised());
    EXPECT_EQ(kept.rows(), n);
    EXPECT_EQ(kept.factor_nonzeros(), c.factor_nonzeros());
    ASSERT_TRUE(c.factorize(a2));  // the original moves on ...
    EXPECT_LT((a2 * c.solve(b) - b).norm(), 1e-12 * b.norm());
    const Eigen::VectorXd xk = kept.solve(b);  // ... the copy still solves a, bit for bit
    EXPECT_EQ((xk - x).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_LT((a * xk - b).norm(), 1e-12 * b.norm());
    ASSERT_TRUE(kept.factorize(a2));  // and the copy can be refactorised in turn
    EXPECT_EQ((kept.solve(b) - c.solve(b)).cwiseAbs().maxCoeff(), 0.0);
  }
}

TEST(SparseCholesky, SolvesSeveralRightHandSidesAsTheirColumnsAlone) {
  // Up to 3 columns on a small factor are solved one at a time (sparse_cholesky.cpp: faster
  // than CHOLMOD's multi-column supernodal path there), bit for bit as the single solves;
  // more columns go through CHOLMOD's block solve. Both solve the system.
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 250;
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i) d(i) = 3.0 + u(rng);
  const Eigen::SparseMatrix<double> a = tridiagonal(d, -1.0);
  for (const int threshold : {0, 1 << 30}) {  // supernodal, simplicial
    SparseCholeskyOptions o;
    o.supernodal_min_unknowns = threshold;
    SparseCholesky c(o);
    ASSERT_TRUE(c.factorize(a));
    for (const int cols : {1, 2, 3, 5}) {
      Eigen::MatrixXd b(n, cols);
      for (Eigen::Index k = 0; k < b.size(); ++k) b.data()[k] = u(rng);
      const Eigen::MatrixXd x = c.solve(b);
      ASSERT_EQ(x.cols(), cols);
      for (int j = 0; j < cols; ++j) {
        const Eigen::VectorXd xj = c.solve(Eigen::VectorXd(b.col(j)));
        EXPECT_LT((a * xj - b.col(j)).norm(), 1e-12 * b.col(j).norm());
        if (cols <= 3) {
          EXPECT_EQ((x.col(j) - xj).cwiseAbs().maxCoeff(), 0.0) << cols << " columns";
        } else {
          EXPECT_LT((x.col(j) - xj).cwiseAbs().maxCoeff(), 1e-13 * xj.cwiseAbs().maxCoeff());
        }
      }
    }
  }
}

/// f(x) = sum_i w_i [(x_i - a_i)^4 / 4 + (x_i - a_i)^2 / 2]: minimum at x = a.
struct Quartic {
  Eigen::VectorXd a, w;
  Eigen::SparseMatrix<double> h;
  NewtonProblem problem() {
    NewtonProblem p;
    p.evaluate = [this](const Eigen::VectorXd& x, NewtonPoint& pt) {
      const Eigen::ArrayXd e = (x - a).array();
      pt.value = (w.array() * (e.pow(4) / 4 + e.square() / 2)).sum();
      pt.grad = (w.array() * (e.cube() + e)).matrix();
      return true;
    };
    p.hessian = [this](const Eigen::VectorXd& x,
                       const Eigen::VectorXd&) -> const Eigen::SparseMatrix<double>& {
      h = tridiagonal((w.array() * (3 * (x - a).array().square() + 1)).matrix());
      return h;
    };
    return p;
  }
};

/// 2-D five-point Laplacian on an m x m grid plus a random positive diagonal: SPD, and large
/// enough that METIS's nested dissection orders it with random choices.
Eigen::SparseMatrix<double> grid_laplacian(int m, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.1, 1.0);
  std::vector<Eigen::Triplet<double>> t;
  const auto id = [m](int i, int j) { return i * m + j; };
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      t.emplace_back(id(i, j), id(i, j), 4.0 + u(rng));
      if (i + 1 < m)
        t.emplace_back(id(i, j), id(i + 1, j), -1.0), t.emplace_back(id(i + 1, j), id(i, j), -1.0);
      if (j + 1 < m)
        t.emplace_back(id(i, j), id(i, j + 1), -1.0), t.emplace_back(id(i, j + 1), id(i, j), -1.0);
    }
  Eigen::SparseMatrix<double> a(m * m, m * m);
  a.setFromTriplets(t.begin(), t.end());
  a.makeCompressed();
  return a;
}

// Solvers analysed on two threads at once give the serial solution bit for bit. Falsifiable:
// METIS keeps one process-wide random state, and without lock_fill_ordering() concurrent
// analyses interleaved its draws (orderings, hence rounding, varied with thread timing).
TEST(SparseCholesky, ConcurrentAnalysesGiveTheSerialSolutionBitForBit) {
  std::mt19937 rng(11);
  const Eigen::SparseMatrix<double> a = grid_laplacian(40, rng);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -1.0, 2.0);
  SparseCholesky serial;
  ASSERT_TRUE(serial.factorize(a));
  const Eigen::VectorXd x = serial.solve(b);
  int differing[2] = {0, 0};
  const auto work = [&](int t) {
    for (int rep = 0; rep < 20; ++rep) {
      SparseCholesky c;
      if (!c.factorize(a) || c.solve(b) != x) ++differing[t];
    }
  };
  std::thread t0(work, 0), t1(work, 1);
  t0.join();
  t1.join();
  EXPECT_EQ(differing[0] + differing[1], 0);
}

TEST(ShiftedNewton, FindsTheMinimumOfASeparableQuarticQuadratically) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 60;
  Quartic q{Eigen::VectorXd(n), Eigen::VectorXd(n), {}};
  for (int i = 0; i < n; ++i) q.a(i) = u(rng), q.w(i) = 2.0 + u(rng);
  ShiftedNewtonOptions o;
  o.block_size = 1;
  o.force_tolerance = 1e-12;
  o.max_factor_reuse = 0;  // plain Newton
  ShiftedNewton newton(o);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(n, 2.0), lambda;
  std::vector<double> residuals;
  const ShiftedNewtonResult r = newton.solve(
      q.problem(), x, lambda, [&](const NewtonIterate& it) { residuals.push_back(it.residual); });
  ASSERT_EQ(r.status, NewtonStatus::converged) << to_string(r.status);
  EXPECT_LT((x - q.a).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(r.factorisations, r.iterations);  // convex: no shift retries, no chord steps
  // Quadratic convergence: once below 1e-2, each residual is below 10 x the previous squared.
  int checked = 0;
  for (size_t k = 1; k < residuals.size(); ++k) {
    if (residuals[k - 1] < 1e-2 && residuals[k - 1] > 1e-7) {
      EXPECT_LT(residuals[k], 10 * residuals[k - 1] * residuals[k - 1]) << k;
      ++checked;
    }
  }
  EXPECT_GE(checked, 1);
}

/// min |x - a|^2 / 2 subject to c(x) = |x|^2 - 1 = 0: x = a/|a|, lambda = (|a| - 1)/2.
struct ClosestPointOnSphere {
  Eigen::Vector3d a{1.5, -2.0, 0.7};
  Eigen::SparseMatrix<double> h;
  NewtonProblem problem() {
    NewtonProblem p;
    p.evaluate = [this](const Eigen::VectorXd& x, NewtonPoint& pt) {
      pt.value = 0.5 * (x - a).squaredNorm();
      pt.grad = x - a;
      pt.c = Eigen::VectorXd::Constant(1, x.squaredNorm() - 1.0);
      pt.c_grad = 2.0 * x;
      return true;
    };
    p.hessian = [this](const Eigen::VectorXd&,
                       const Eigen::VectorXd& l) -> const Eigen::SparseMatrix<double>& {
      h = tridiagonal(Eigen::VectorXd::Constant(3, 1.0 + 2.0 * l(0)));
      return h;
    };
    p.constraint_scale = Eigen::VectorXd::Ones(1);
    return p;
  }
};

TEST(ShiftedNewton, ClosestPointOfASphereWithItsLagrangeMultiplier) {
  ClosestPointOnSphere sphere;
  const Eigen::Vector3d a = sphere.a;
  const NewtonProblem p = sphere.problem();
  ShiftedNewtonOptions o;
  o.force_tolerance = 1e-13;
  o.constraint_tolerance = 1e-14;
  ShiftedNewton newton(o);
  Eigen::VectorXd x = Eigen::Vector3d(0.2, 0.9, -0.3), lambda = Eigen::VectorXd::Zero(1);
  const ShiftedNewtonResult r = newton.solve(p, x, lambda);
  ASSERT_EQ(r.status, NewtonStatus::converged) << to_string(r.status);
  EXPECT_LT((x - a / a.norm()).norm(), 1e-12);
  EXPECT_NEAR(lambda(0), 0.5 * (a.norm() - 1.0), 1e-12);
}

/// The double well f = sum (x_i^2 - 1)^2 / 4 (minima |x_i| = 1, f'' = 3 x^2 - 1), its Hessian
/// assembled into `h`.
NewtonProblem double_well(Eigen::SparseMatrix<double>& h) {
  NewtonProblem p;
  p.evaluate = [](const Eigen::VectorXd& x, NewtonPoint& pt) {
    const Eigen::ArrayXd s = x.array().square() - 1.0;
    pt.value = (s.square() / 4).sum();
    pt.grad = (s * x.array()).matrix();
    return true;
  };
  p.hessian = [&h](const Eigen::VectorXd& x,
                   const Eigen::VectorXd&) -> const Eigen::SparseMatrix<double>& {
    h = tridiagonal((3 * x.array().square() - 1).matrix());
    return h;
  };
  return p;
}

TEST(ShiftedNewton, ShiftsThroughANegativeCurvatureStart) {
  // Double well f = sum (x_i^2 - 1)^2 / 4 from x_i = 0.1 (f'' = 3 x^2 - 1 < 0): the shifted
  // steps still descend, and the minimum |x_i| = 1 is reached.
  const int n = 10;
  Eigen::SparseMatrix<double> h;
  const NewtonProblem p = double_well(h);
  ShiftedNewtonOptions o;
  o.block_size = 1;
  o.force_tolerance = 1e-12;
  o.max_step = 0.5;
  ShiftedNewton newton(o);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(n, 0.1), lambda;
  const ShiftedNewtonResult r = newton.solve(p, x, lambda);
  ASSERT_EQ(r.status, NewtonStatus::converged) << to_string(r.status);
  EXPECT_LT((x.cwiseAbs().array() - 1.0).abs().maxCoeff(), 1e-12);
  EXPECT_GT(r.largest_shift, 1.0);  // the first Hessian needed a shift above its own scale
  EXPECT_GT(r.factorisations, r.iterations);
}

TEST(ShiftedNewton, ANonConvergedSolveReturnsItsBestIterate) {
  // Double well from x_i = 0.1 as above: the residual |x (x^2 - 1)| rises from 0.099 while
  // the shifted steps descend towards the minimum (it peaks at x = 1/sqrt3). Stopped within a
  // few iterations, the solve must hand back the iterate with the smallest residual and that
  // iterate's residual, not the last one.
  const int n = 10;
  Eigen::SparseMatrix<double> h;
  const NewtonProblem p = double_well(h);
  const auto residual_at = [](const Eigen::VectorXd& x) {
    return (x.array() * (x.array().square() - 1.0)).abs().maxCoeff();
  };
  const double start_residual = residual_at(Eigen::VectorXd::Constant(n, 0.1));
  for (const int iterations : {1, 3}) {
    ShiftedNewtonOptions o;
    o.block_size = 1;
    o.max_step = 0.5;
    o.max_iterations = iterations;
    ShiftedNewton newton(o);
    Eigen::VectorXd x = Eigen::VectorXd::Constant(n, 0.1), lambda;
    std::vector<double> seen;
    const ShiftedNewtonResult r =
        newton.solve(p, x, lambda, [&](const NewtonIterate& it) { seen.push_back(it.residual); });
    ASSERT_EQ(r.status, NewtonStatus::max_iterations) << iterations;
    ASSERT_GT(seen.back(), seen.front()) << "the residual must have risen for this test to bite";
    EXPECT_DOUBLE_EQ(r.residual, *std::min_element(seen.begin(), seen.end())) << iterations;
    EXPECT_DOUBLE_EQ(r.residual, residual_at(x)) << iterations;
    EXPECT_LE(r.residual, start_residual) << iterations;
  }
}

TEST(ShiftedNewton, ReportsAFactorisationFailureAsSuch) {
  // f = -|x|^2/2 has Hessian -I: no shift within two attempts (1e-8, 1e-4) makes it definite.
  Eigen::SparseMatrix<double> h = tridiagonal(Eigen::VectorXd::Constant(4, -1.0));
  NewtonProblem p;
  p.evaluate = [](const Eigen::VectorXd& x, NewtonPoint& pt) {
    pt.value = -0.5 * x.squaredNorm();
    pt.grad = -x;
    return true;
  };
  p.hessian = [&](const Eigen::VectorXd&,
                  const Eigen::VectorXd&) -> const Eigen::SparseMatrix<double>& { return h; };
  ShiftedNewtonOptions o;
  o.max_shift_attempts = 2;
  o.block_size = 1;
  ShiftedNewton newton(o);
  Eigen::VectorXd x = Eigen::VectorXd::Ones(4), lambda;
  const ShiftedNewtonResult r = newton.solve(p, x, lambda);
  EXPECT_EQ(r.status, NewtonStatus::factorisation_failed);
  EXPECT_EQ(to_string(r.status), "factorisation failed");
  EXPECT_EQ(r.factorisations, 2);
  EXPECT_EQ(x, Eigen::VectorXd::Ones(4));  // never moved
}

TEST(ShiftedNewton, ReusesTheFactorisationAcrossCallsAndReachesTheSameMinimum) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 40;
  Quartic q{Eigen::VectorXd(n), Eigen::VectorXd(n), {}};
  for (int i = 0; i < n; ++i) q.a(i) = u(rng), q.w(i) = 2.0 + u(rng);
  ShiftedNewtonOptions o;
  o.block_size = 1;
  o.force_tolerance = 1e-11;
  o.reuse_across_calls = true;
  o.reuse_contraction = 0.7;
  ShiftedNewton newton(o);
  Eigen::VectorXd x = q.a + Eigen::VectorXd::Constant(n, 0.3), lambda;
  const NewtonProblem p = q.problem();
  ASSERT_EQ(newton.solve(p, x, lambda).status, NewtonStatus::converged);
  q.a.array() += 1e-3;  // a nearby problem: its Hessian differs from the kept one by ~1e-5
  const ShiftedNewtonResult r = newton.solve(p, x, lambda);
  ASSERT_EQ(r.status, NewtonStatus::converged) << to_string(r.status);
  EXPECT_GE(r.chord_steps, 1);
  EXPECT_EQ(r.factorisations, 0);  // every step of the second call was a chord step
  EXPECT_LT((x - q.a).cwiseAbs().maxCoeff(), 1e-11);
}

/// f(x) = sum_i [w_i (x_i - a_i)^4 / 4 + d_i x_i^2 / 2] on the plane sum_i x_i = S, with
/// d_0 < 0 and w_0 = 0: d2f is indefinite everywhere (d2f_00 = d_0), but the reduced Hessian on
/// the plane is positive definite where sum_i 1 / d2f_ii < 0 (diagonal d2f with one negative
/// entry), so the constrained minimum is a regular one.
struct IndefiniteOnAPlane {
  Eigen::VectorXd a, w, d;
  double total = 1.0;
  Eigen::SparseMatrix<double> h;
  Eigen::VectorXd curvature(const Eigen::VectorXd& x) const {
    return (d.array() + 3 * w.array() * (x - a).array().square()).matrix();
  }
  NewtonProblem problem() {
    NewtonProblem p;
    p.evaluate = [this](const Eigen::VectorXd& x, NewtonPoint& pt) {
      const Eigen::ArrayXd e = (x - a).array();
      pt.value = (w.array() * e.pow(4) / 4 + d.array() * x.array().square() / 2).sum();
      pt.grad = (w.array() * e.cube() + d.array() * x.array()).matrix();
      pt.c = Eigen::VectorXd::Constant(1, x.sum() - total);
      pt.c_grad = Eigen::MatrixXd::Ones(x.size(), 1);
      return true;
    };
    p.hessian = [this](const Eigen::VectorXd& x,
                       const Eigen::VectorXd&) -> const Eigen::SparseMatrix<double>& {
      h = tridiagonal(curvature(x));
      return h;
    };
    p.constraint_scale = Eigen::VectorXd::Ones(1);
    return p;
  }
  /// n unknowns: d_0 = -0.5, w_0 = 0, the others' d in [8, 12] and w in [1, 3], a in [-1, 1].
  static IndefiniteOnAPlane random(int n, unsigned seed) {
    IndefiniteOnAPlane q;
    q.a.resize(n);
    q.w.resize(n);
    q.d.resize(n);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < n; ++i) {
      q.a(i) = u(rng);
      q.w(i) = i == 0 ? 0.0 : 2.0 + u(rng);
      q.d(i) = i == 0 ? -0.5 : 10.0 + 2.0 * u(rng);
    }
    return q;
  }
};

TEST(ShiftedNewton, KrylovCorrectionKeepsNewtonQuadraticWhereOnlyTheReducedHessianIsPositive) {
  const int n = 12;
  IndefiniteOnAPlane q = IndefiniteOnAPlane::random(n, 11);
  auto solve = [&](int krylov, std::vector<double>& residuals, Eigen::VectorXd& x,
                   Eigen::VectorXd& lambda) {
    ShiftedNewtonOptions o;
    o.block_size = 1;
    o.force_tolerance = 1e-11;
    o.constraint_tolerance = 1e-12;
    o.max_factor_reuse = 0;  // plain Newton apart from the correction
    o.krylov_iterations = krylov;
    o.krylov_tolerance = 1e-10;
    ShiftedNewton newton(o);
    x = Eigen::VectorXd::Constant(n, q.total / n);
    lambda.resize(0);
    residuals.clear();
    return newton.solve(q.problem(), x, lambda,
                        [&](const NewtonIterate& it) { residuals.push_back(it.residual); });
  };
  std::vector<double> rk, rp;
  Eigen::VectorXd xk, lk, xp, lp;
  const ShiftedNewtonResult with = solve(n, rk, xk, lk);
  const ShiftedNewtonResult without = solve(0, rp, xp, lp);
  ASSERT_EQ(with.status, NewtonStatus::converged);
  // Independent truth: the KKT conditions and the second-order condition at the result.
  NewtonPoint pt;
  ASSERT_TRUE(q.problem().evaluate(xk, pt));
  EXPECT_LT((pt.grad + lk(0) * Eigen::VectorXd::Ones(n)).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT(std::abs(xk.sum() - q.total), 1e-12);
  const Eigen::VectorXd k = q.curvature(xk);
  EXPECT_LT(k(0), 0.0);                    // d2f indefinite at the minimum ...
  EXPECT_LT(k.cwiseInverse().sum(), 0.0);  // ... the reduced Hessian positive definite
  EXPECT_GT(with.largest_shift, ShiftedNewtonOptions{}.initial_shift);  // a shift was needed
  // The corrected Newton steps converge quadratically: from a residual below 1e-2 each step
  // squares it (up to a constant), so at most 4 more iterations reach 1e-11.
  int from = 0;
  while (from < static_cast<int>(rk.size()) && rk[from] > 1e-2) ++from;
  EXPECT_LE(static_cast<int>(rk.size()) - 1 - from, 4);
  for (size_t i = from + 1; i < rk.size(); ++i) EXPECT_LT(rk[i], 10.0 * rk[i - 1] * rk[i - 1]);
  // The shift alone converges linearly there (or not at all within the budget), to the same
  // minimum when it does.
  EXPECT_GT(without.iterations, 2 * with.iterations)
      << "corrected " << with.iterations << ", shifted only " << without.iterations;
  if (without.status == NewtonStatus::converged) {
    EXPECT_LT((xp - xk).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(ShiftedNewton, LaggedCorrectionCappedAtOneCgIterationReachesTheSameMinimum) {
  // The lagged correction undoes the shift of the factorised Hessian; capped at one CG
  // iteration (krylov_lagged_iterations = 1) it spends at most one per Newton iteration and
  // still converges to the constrained minimum (KKT conditions at the result).
  const int n = 12;
  IndefiniteOnAPlane q = IndefiniteOnAPlane::random(n, 11);
  auto solve = [&](int cap, Eigen::VectorXd& x, Eigen::VectorXd& lambda) {
    ShiftedNewtonOptions o;
    o.block_size = 1;
    o.force_tolerance = 1e-11;
    o.constraint_tolerance = 1e-12;
    o.max_iterations = 500;
    o.krylov_iterations = n;
    o.krylov_tolerance = 1e-10;
    o.krylov_lagged_hessian = true;
    o.krylov_lagged_iterations = cap;
    o.max_factor_reuse = 1000;
    ShiftedNewton newton(o);
    x = Eigen::VectorXd::Constant(n, q.total / n);
    lambda.resize(0);
    return newton.solve(q.problem(), x, lambda);
  };
  Eigen::VectorXd x1, l1, xa, la;
  const ShiftedNewtonResult capped = solve(1, x1, l1);
  const ShiftedNewtonResult full = solve(0, xa, la);
  ASSERT_EQ(capped.status, NewtonStatus::converged) << to_string(capped.status);
  ASSERT_EQ(full.status, NewtonStatus::converged) << to_string(full.status);
  // The problem needs a grown shift, so an uncapped lagged correction takes several CG
  // iterations per Newton iteration; the capped one never more than one.
  EXPECT_GT(full.largest_shift, ShiftedNewtonOptions{}.initial_shift);
  EXPECT_GT(full.krylov_iterations, full.iterations);
  EXPECT_LE(capped.krylov_iterations, capped.iterations);
  NewtonPoint pt;
  ASSERT_TRUE(q.problem().evaluate(x1, pt));
  EXPECT_LT((pt.grad + l1(0) * Eigen::VectorXd::Ones(n)).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT(std::abs(x1.sum() - q.total), 1e-12);
  EXPECT_LT((x1 - xa).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(ShiftedNewton, LaggedConstraintSolvesReachTheClosestPointOfASphere) {
  // The sphere's closest point by chord steps that keep both the factorisation and K^-1 C
  // (krylov_lagged_constraints): the curved constraint's gradient 2x changes from step to
  // step, and the answer must not.
  ClosestPointOnSphere sphere;
  const Eigen::Vector3d a = sphere.a;
  const NewtonProblem p = sphere.problem();
  for (const bool lag : {false, true}) {
    ShiftedNewtonOptions o;
    o.force_tolerance = 1e-13;
    o.constraint_tolerance = 1e-14;
    o.max_iterations = 200;
    o.krylov_iterations = 3;
    o.krylov_lagged_hessian = true;
    o.krylov_lagged_iterations = 1;
    o.krylov_lagged_constraints = lag;
    o.max_factor_reuse = 1000;
    o.reuse_contraction = 0.9;
    ShiftedNewton newton(o);
    Eigen::VectorXd x = Eigen::Vector3d(0.2, 0.9, -0.3), lambda = Eigen::VectorXd::Zero(1);
    const ShiftedNewtonResult r = newton.solve(p, x, lambda);
    ASSERT_EQ(r.status, NewtonStatus::converged) << to_string(r.status) << " lagged " << lag;
    EXPECT_GE(r.chord_steps, 2) << "lagged " << lag;  // the lagged solves were used
    EXPECT_LT((x - a / a.norm()).norm(), 1e-12) << "lagged " << lag;
    EXPECT_NEAR(lambda(0), 0.5 * (a.norm() - 1.0), 1e-12) << "lagged " << lag;
  }
}

TEST(ShiftedNewton, OptionsAreValidated) {
  ShiftedNewtonOptions o;
  o.reuse_contraction = 1.5;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.max_step = 0.0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.armijo = 0.7;
  EXPECT_THROW(ShiftedNewton{o}, std::invalid_argument);
  o = {};
  o.krylov_lagged_iterations = -1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
