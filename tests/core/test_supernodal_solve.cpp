// SPDX-License-Identifier: GPL-3.0-or-later
// The single-precision solve of a supernodal factor (core/supernodal_solve.hpp, through
// SparseCholeskyOptions::solve_precision) against the double one: the error float rounding
// allows and no less (it is a float solve), the same bits for one or several right-hand sides
// and for a clone, and the double solve wherever the float one does not apply (a simplicial
// factor, entries or a right-hand side beyond float's range). And the factorisation in single
// precision (core/supernodal_factor.hpp, SolvePrecision::single_precision_factorisation): a
// factor of the matrix to float rounding (residuals, against the double factor), the same
// definiteness verdict as the double factorisation on either side of the smallest eigenvalue,
// the same bits run to run, for a clone and with the shift given apart, and the double
// factorisation wherever float cannot hold the matrix or the solution.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <limits>
#include <random>
#include <vector>

#include "core/sparse_cholesky.hpp"

namespace rbc {
namespace {

/// A 2-D grid of m x m nodes with 3 unknowns each (lower triangle, full 3 x 3 blocks, as the
/// discrete Hessian): node blocks 12.1 I + a random symmetric part (entries < 0.1) on the
/// diagonal, -w I (w in [0.5, 1], per pair) to each of the 8 neighbours of the 9-point
/// stencil. Diagonally dominant, hence SPD with condition number ~ 10; METIS orders it into
/// supernodes from 1 to a few hundred columns wide, row counts of every remainder mod 4.
Eigen::SparseMatrix<double> block_grid_lower(int m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 3 * m * m;
  std::vector<Eigen::Triplet<double>> t;
  auto node = [m](int i, int j) { return i * m + j; };
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      const int a = node(i, j);
      Eigen::Matrix3d d = Eigen::Matrix3d::Identity() * 12.1;
      Eigen::Matrix3d r;
      for (double& v : r.reshaped()) v = 0.05 * u(rng);
      d += r + r.transpose();
      for (int p = 0; p < 3; ++p)
        for (int q = 0; q <= p; ++q) t.emplace_back(3 * a + p, 3 * a + q, d(p, q));
      const int di[4] = {0, 1, 1, 1}, dj[4] = {1, -1, 0, 1};
      for (int k = 0; k < 4; ++k) {
        const int i2 = i + di[k], j2 = j + dj[k];
        if (i2 >= m || j2 < 0 || j2 >= m) continue;
        const int b = node(i2, j2);  // b > a: the block (b, a) is in the lower triangle
        const double w = 0.5 + 0.5 * (u(rng) + 1.0) / 2.0;
        for (int p = 0; p < 3; ++p)
          for (int q = 0; q < 3; ++q) t.emplace_back(3 * b + p, 3 * a + q, p == q ? -w : 0.0);
      }
    }
  Eigen::SparseMatrix<double> a(n, n);
  a.setFromTriplets(t.begin(), t.end());
  a.makeCompressed();
  return a;
}

/// n entries uniform in [-1, 1], from `seed`.
Eigen::VectorXd random_vector(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd b(n);
  for (double& v : b) v = u(rng);
  return b;
}

/// The full symmetric matrix of a lower triangle.
Eigen::SparseMatrix<double> symmetric_of(const Eigen::SparseMatrix<double>& lower) {
  Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  return full;
}

SparseCholeskyOptions precision(SolvePrecision p) {
  SparseCholeskyOptions o;
  o.solve_precision = p;
  return o;
}

/// `scale` a, a matrix whose entries float cannot hold (beyond its range, or subnormal), is
/// factorised and solved in double whatever the precision asked for: exact to double rounding.
void expect_double_solve_of_scaled(SolvePrecision p, const Eigen::SparseMatrix<double>& a,
                                   double scale, const Eigen::VectorXd& b) {
  const Eigen::SparseMatrix<double> scaled = scale * a;
  SparseCholesky s(precision(p));
  ASSERT_TRUE(s.factorize(scaled));
  const Eigen::VectorXd x = s.solve(b);
  EXPECT_LT((symmetric_of(scaled) * x - b).norm(), 1e-12 * b.norm()) << scale;
}

TEST(SinglePrecisionSolve, ErrsByFloatRoundingAndNoMore) {
  const Eigen::SparseMatrix<double> a = block_grid_lower(40, 7);  // 4,800 unknowns
  const Eigen::SparseMatrix<double> full = symmetric_of(a);
  const Eigen::VectorXd b = random_vector(a.rows(), 11);
  SparseCholesky dbl(precision(SolvePrecision::double_precision));
  SparseCholesky sgl(precision(SolvePrecision::single_precision));
  ASSERT_TRUE(dbl.factorize(a));
  ASSERT_TRUE(sgl.factorize(a));
  const Eigen::VectorXd xd = dbl.solve(b), xs = sgl.solve(b);
  // The double solve is exact to ~1e-15; the float one to its rounding, u = 6e-8, times the
  // condition number (~10) and a growth with the length of the sums (the residual's bound is
  // ~ n_row u |L||L'| |x|; measured: 1.1e-7 both): below 1e-6, far above double rounding.
  EXPECT_LT((full * xd - b).norm(), 1e-13 * b.norm());
  const double error = (xs - xd).norm() / xd.norm();
  EXPECT_LT(error, 1e-6);
  EXPECT_GT(error, 1e-12);  // a float solve, not the double one
  EXPECT_LT((full * xs - b).norm(), 1e-6 * b.norm());
}

TEST(SinglePrecisionSolve, SeveralColumnsAndAClonesSolveGiveTheSameBits) {
  const Eigen::SparseMatrix<double> a = block_grid_lower(23, 3);  // 1,587 unknowns
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd b(a.rows(), 3);
  for (double& v : b.reshaped()) v = u(rng);
  SparseCholesky c(precision(SolvePrecision::single_precision));
  ASSERT_TRUE(c.factorize(a));
  const Eigen::MatrixXd x = c.solve(b);
  const SparseCholesky copy = c.clone();
  for (Eigen::Index j = 0; j < b.cols(); ++j) {
    const Eigen::VectorXd xj = c.solve(Eigen::VectorXd(b.col(j)));
    EXPECT_EQ(xj, Eigen::VectorXd(x.col(j))) << "column " << j;
    EXPECT_EQ(copy.solve(Eigen::VectorXd(b.col(j))), xj) << "column " << j;
  }
  // A refactorisation (another matrix, same pattern) replaces the float copy.
  const Eigen::SparseMatrix<double> a2 = 2.0 * a;
  ASSERT_TRUE(c.factorize(a2));
  const Eigen::VectorXd half = c.solve(Eigen::VectorXd(b.col(0)));
  EXPECT_LT((2.0 * half - x.col(0)).norm(), 1e-5 * x.col(0).norm());
}

TEST(SinglePrecisionSolve, FallsBackToTheDoubleSolveWhereFloatDoesNotApply) {
  const Eigen::SparseMatrix<double> a = block_grid_lower(12, 9);  // 432 unknowns
  const Eigen::VectorXd b = random_vector(a.rows(), 2);
  // A simplicial factor: the double solve, bit for bit.
  {
    SparseCholeskyOptions o = precision(SolvePrecision::single_precision);
    o.supernodal_min_unknowns = 1 << 30;
    SparseCholeskyOptions od = o;
    od.solve_precision = SolvePrecision::double_precision;
    SparseCholesky s(o), d(od);
    ASSERT_TRUE(s.factorize(a));
    ASSERT_TRUE(d.factorize(a));
    EXPECT_EQ(s.solve(b), d.solve(b));
  }
  // Entries beyond float's range (the matrix scaled by 1e80, its factor by 1e40): the double
  // solve (a float solve could not even hold the entries).
  expect_double_solve_of_scaled(SolvePrecision::single_precision, a, 1e80, b);
  // A right-hand side beyond float's range (1e40) on a factor within it: the float solve would
  // give infinities; the double one answers, exact to double rounding.
  {
    SparseCholesky s(precision(SolvePrecision::single_precision));
    ASSERT_TRUE(s.factorize(a));
    const Eigen::VectorXd huge = 1e40 * b;
    const Eigen::VectorXd x = s.solve(huge);
    ASSERT_TRUE(x.allFinite());
    EXPECT_LT((symmetric_of(a) * x - huge).norm(), 1e-12 * huge.norm());
    Eigen::MatrixXd two(huge.size(), 2);
    two << huge, b;
    const Eigen::MatrixXd y = s.solve(two);
    EXPECT_EQ(Eigen::VectorXd(y.col(0)), x);
    EXPECT_EQ(Eigen::VectorXd(y.col(1)), s.solve(b));
  }
}

TEST(SinglePrecisionFactorisation, FactorsTheMatrixToFloatRounding) {
  // 4,800 unknowns: supernodes of 3 to a few hundred columns, each updated by up to dozens of
  // descendants, so every branch of the left-looking loop runs (a skipped or misplaced update
  // would leave residuals of ~(w / 12)^2 ~ 1e-3, not 1e-7).
  const Eigen::SparseMatrix<double> a = block_grid_lower(40, 7);
  const Eigen::SparseMatrix<double> full = symmetric_of(a);
  const Eigen::VectorXd b = random_vector(a.rows(), 13);
  SparseCholesky dbl(precision(SolvePrecision::double_precision));
  SparseCholesky rounded(precision(SolvePrecision::single_precision));
  SparseCholesky sgl(precision(SolvePrecision::single_precision_factorisation));
  ASSERT_TRUE(dbl.factorize(a));
  ASSERT_TRUE(rounded.factorize(a));
  ASSERT_TRUE(sgl.factorize(a));
  const Eigen::VectorXd xd = dbl.solve(b), xr = rounded.solve(b), xs = sgl.solve(b);
  // Float rounding in the factorisation too: the same order as the rounded double factor's
  // solve (measured 1.1e-7 there), far above double rounding.
  const double error = (xs - xd).norm() / xd.norm();
  EXPECT_LT(error, 1e-6);
  EXPECT_GT(error, 1e-12);
  EXPECT_LT(error, 10.0 * (xr - xd).norm() / xd.norm() + 1e-7);
  EXPECT_LT((full * xs - b).norm(), 1e-6 * b.norm());
  // Several right-hand sides at once: column by column, the same bits.
  Eigen::MatrixXd two(b.size(), 2);
  two << b, 2.0 * b;
  const Eigen::MatrixXd y = sgl.solve(two);
  EXPECT_EQ(Eigen::VectorXd(y.col(0)), xs);
}

TEST(SinglePrecisionFactorisation, FindsTheSameDefinitenessAsTheDoubleFactorisation) {
  const Eigen::SparseMatrix<double> a = block_grid_lower(12, 9);  // 432 unknowns
  const Eigen::MatrixXd dense = Eigen::MatrixXd(symmetric_of(a));
  const double lowest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues()(0);
  ASSERT_GT(lowest, 1.0);  // the grid is diagonally dominant
  const Eigen::VectorXd b = random_vector(a.rows(), 4);
  // Shifted to just above / below the smallest eigenvalue (by 1e-3 of the diagonal, ~1e4 float
  // roundings): definite, then indefinite, in float as in double. The indefinite one fails
  // wherever its pivot turns negative, so the verdict is the factorisation's, not a first pivot.
  for (const double margin : {1e-2, -1e-2}) {
    SparseCholesky dbl(precision(SolvePrecision::double_precision));
    SparseCholesky sgl(precision(SolvePrecision::single_precision_factorisation));
    const bool definite = margin > 0.0;
    EXPECT_EQ(dbl.factorize(a, -lowest + margin), definite) << margin;
    EXPECT_EQ(sgl.factorize(a, -lowest + margin), definite) << margin;
    EXPECT_EQ(sgl.factorised(), definite);
    if (!definite) continue;
    // Condition number ~ 20 / 1e-2: the float factor's error grows with it, and the
    // preconditioner's solve stays a solve (residual to ~ cond 1e-7).
    const Eigen::VectorXd xd = dbl.solve(b), xs = sgl.solve(b);
    EXPECT_LT((xs - xd).norm() / xd.norm(), 2e3 * 1e-6);
  }
  // A diagonal entry a does not store gets the shift too, as in double: a tridiagonal matrix,
  // diagonal 4 but (20, 20) missing, shifted by 4, is definite and factorised exactly.
  {
    std::vector<Eigen::Triplet<double>> t;
    for (int k = 0; k < 50; ++k) {
      if (k != 20) t.emplace_back(k, k, 4.0);
      if (k + 1 < 50) t.emplace_back(k + 1, k, -1.0);
    }
    Eigen::SparseMatrix<double> tri(50, 50);
    tri.setFromTriplets(t.begin(), t.end());
    SparseCholeskyOptions o = precision(SolvePrecision::single_precision_factorisation);
    o.supernodal_min_unknowns = 0;
    SparseCholesky dbl(precision(SolvePrecision::double_precision)), sgl(o);
    ASSERT_TRUE(dbl.factorize(tri, 4.0));
    ASSERT_TRUE(sgl.factorize(tri, 4.0));
    const Eigen::VectorXd c = Eigen::VectorXd::Ones(50);
    EXPECT_LT((sgl.solve(c) - dbl.solve(c)).norm(), 1e-6 * dbl.solve(c).norm());
  }
  // The shift given apart is the shift added to the diagonal, bit for bit.
  Eigen::SparseMatrix<double> shifted = a;
  for (int k = 0; k < shifted.rows(); ++k) shifted.coeffRef(k, k) += 0.5;
  SparseCholesky s1(precision(SolvePrecision::single_precision_factorisation));
  SparseCholesky s2(precision(SolvePrecision::single_precision_factorisation));
  ASSERT_TRUE(s1.factorize(a, 0.5));
  ASSERT_TRUE(s2.factorize(shifted));
  EXPECT_EQ(s1.solve(b), s2.solve(b));
}

TEST(SinglePrecisionFactorisation, IsReproducibleAndClonesKeepTheirFactor) {
  const Eigen::SparseMatrix<double> a = block_grid_lower(23, 3);  // 1,587 unknowns
  const Eigen::VectorXd b = random_vector(a.rows(), 8);
  SparseCholesky c(precision(SolvePrecision::single_precision_factorisation));
  SparseCholesky again(precision(SolvePrecision::single_precision_factorisation));
  ASSERT_TRUE(c.factorize(a));
  ASSERT_TRUE(again.factorize(a));
  const Eigen::VectorXd x = c.solve(b);
  EXPECT_EQ(again.solve(b), x);
  const SparseCholesky copy = c.clone();
  ASSERT_TRUE(c.factorize(2.0 * a));  // the original refactorised: the copy keeps a's factor
  EXPECT_EQ(copy.solve(b), x);
  EXPECT_LT((2.0 * c.solve(b) - x).norm(), 1e-5 * x.norm());
}

TEST(SinglePrecisionFactorisation, FactorisesInDoubleWhereFloatCannotHoldTheProblem) {
  const Eigen::SparseMatrix<double> a = block_grid_lower(12, 9);  // 432 unknowns
  const Eigen::VectorXd b = random_vector(a.rows(), 6);
  // Entries beyond float's range, or so small they are subnormal in float (1e-40): factorised
  // and solved in double.
  for (const double scale : {1e80, 1e-40})
    expect_double_solve_of_scaled(SolvePrecision::single_precision_factorisation, a, scale, b);
  // A right-hand side beyond float's range on a float factor: the double factorisation is made
  // then, and answers exactly; an ordinary right-hand side afterwards is still the float solve.
  // After a refactorisation (of 2a) that double factor is not reused, in the object or in a
  // clone made before; a clone made after makes its own.
  {
    SparseCholesky s(precision(SolvePrecision::single_precision_factorisation));
    ASSERT_TRUE(s.factorize(a));
    const SparseCholesky early = s.clone();
    const Eigen::VectorXd before = s.solve(b);
    const Eigen::VectorXd huge = 1e40 * b;
    const Eigen::VectorXd x = s.solve(huge);
    ASSERT_TRUE(x.allFinite());
    EXPECT_LT((symmetric_of(a) * x - huge).norm(), 1e-12 * huge.norm());
    EXPECT_EQ(s.solve(b), before);
    const Eigen::SparseMatrix<double> a2 = 2.0 * a;
    ASSERT_TRUE(s.factorize(a2));
    const SparseCholesky late = s.clone();
    for (const SparseCholesky* c : {static_cast<const SparseCholesky*>(&s), &late}) {
      const Eigen::VectorXd y = c->solve(huge);
      EXPECT_LT((symmetric_of(a2) * y - huge).norm(), 1e-12 * huge.norm());
    }
    EXPECT_LT((symmetric_of(a) * early.solve(huge) - huge).norm(), 1e-12 * huge.norm());
    // A NaN right-hand side: a NaN answer, as in double.
    Eigen::VectorXd nan = b;
    nan(3) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(s.solve(nan).allFinite());
  }
  // A NaN entry, on the diagonal or off it: not positive definite in every precision, no
  // factor (OpenBLAS's dpotrf had let a NaN pivot through as a success).
  for (const int column : {5, 6})
    for (const SolvePrecision p :
         {SolvePrecision::double_precision, SolvePrecision::single_precision,
          SolvePrecision::single_precision_factorisation}) {
      Eigen::SparseMatrix<double> bad = a;
      bad.coeffRef(6, column) = std::numeric_limits<double>::quiet_NaN();
      SparseCholesky s(precision(p));
      EXPECT_FALSE(s.factorize(bad)) << column;
      EXPECT_FALSE(s.factorised()) << column;
    }
}

}  // namespace
}  // namespace rbc
