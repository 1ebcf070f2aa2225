// SPDX-License-Identifier: GPL-3.0-or-later
// Invariant-form laws Psi_p(I1, I2) and the anisotropic lattice density Psi(F):
// Appendix A against GSL quadrature over the lattice orientation, symmetry and isotropy,
// finite-difference tests of every derivative, and the domain.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>

#include "core/units.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/lattice_density.hpp"

namespace rbc {
namespace {

constexpr double kPi = units::pi;

Eigen::Matrix2d rotation(double t) {
  return Eigen::Rotation2Dd(t).toRotationMatrix();
}

// A set of deformations: stretch, compression, shear, mixed; all with det F > 0 and every
// link below Lmax (largest principal stretch < 1/x0 = 3.17).
std::vector<Eigen::Matrix2d> sample_deformations() {
  std::vector<Eigen::Matrix2d> out;
  Eigen::Matrix2d F;
  F << 1.3, 0.0, 0.0, 0.9;
  out.push_back(F);
  F << 1.1, 0.4, -0.1, 0.85;
  out.push_back(F);
  F << 2.4, 0.3, 0.2, 0.6;
  out.push_back(F);
  F << 0.8, 0.05, 0.0, 0.75;
  out.push_back(F);
  F << 1.0, 1.2, 0.0, 1.0;
  out.push_back(F);
  return out;
}

// Appendix A, literally as printed: the lattice sums S_j = sum_i (xi_i^T C xi_i - 1)^j.
double appendix_sum(int j, double I1, double I2) {
  switch (j) {
    case 0:
      return 6.0;
    case 1:
      return 3 * I2;
    case 2:
      return 0.75 * (4 * I2 - 8 * I1 + 3 * I2 * I2 - 4 * I1 * I1);
    case 3:
      return 3.0 / 8.0 * I2 * (12 * I2 + 5 * I2 * I2 - 12 * I1 * I1 - 24 * I1);
    case 4:
      return 3.0 / 64.0 *
             (192 * std::pow(I1, 3) + 48 * std::pow(I1, 4) - 240 * I2 * I2 * I1 -
              120 * I2 * I2 * I1 * I1 + 35 * std::pow(I2, 4) + 192 * I1 * I1 + 48 * I2 * I2 -
              192 * I2 * I1 - 96 * I2 * I1 * I1 + 120 * std::pow(I2, 3));
  }
  return 0.0;
}

double lattice_sum(int j, const Eigen::Matrix2d& F, double phi) {
  const Eigen::Matrix2d C = F.transpose() * F;
  double s = 0.0;
  for (int i = 0; i < 6; ++i) {
    const Eigen::Vector2d xi(std::cos(phi + i * kPi / 3), std::sin(phi + i * kPi / 3));
    s += std::pow(xi.dot(C * xi) - 1.0, j);
  }
  return s;
}

TEST(AppendixA, OrientationAveragedSumsMatchGslQuadrature) {
  for (const Eigen::Matrix2d& F : sample_deformations()) {
    const Invariants I = invariants(F);
    for (int j = 0; j <= 4; ++j) {
      const double avg =
          average_over_angle([&](double phi) { return lattice_sum(j, F, phi); }, kPi / 3.0, 1e-13);
      EXPECT_NEAR(appendix_sum(j, I.i1, I.i2), avg, 1e-11 * (1.0 + std::abs(avg)))
          << "j = " << j << "\nF =\n"
          << F;
    }
    // j <= 2 need no average: every orientation gives the same sum.
    for (int j = 1; j <= 2; ++j)
      EXPECT_NEAR(lattice_sum(j, F, 0.37), appendix_sum(j, I.i1, I.i2),
                  1e-12 * (1 + std::abs(lattice_sum(j, F, 0.37))));
  }
}

TEST(AppendixA, UnaveragedThirdOrderSumHasTheCos6PhiTerm) {
  // F = diag(l1, l2): phi is the angle of the lattice to the first principal axis.
  Eigen::Matrix2d F;
  F << 1.7, 0.0, 0.0, 0.8;
  const Invariants I = invariants(F);
  const double disc = I.i2 * I.i2 + 4 * I.i2 - 4 * I.i1 * I.i1 - 8 * I.i1;
  for (double phi : {0.0, 0.2, 0.5, 1.0}) {
    const double expected =
        appendix_sum(3, I.i1, I.i2) + 3.0 / 16.0 * std::pow(disc, 1.5) * std::cos(6 * phi);
    EXPECT_NEAR(lattice_sum(3, F, phi), expected, 1e-12 * std::abs(expected));
  }
}

struct LawFixture {
  WlcParameters p;
  StericParameters s;
  WlcDensity w(WlcExpansion e) const { return make_wlc_density(p, e); }
  double C() const { return steric_constant(make_wlc_density(p), s); }
};

TEST(InvariantLaws, EqualTheLatticeDensityAveragedOverOrientation) {
  const LawFixture fx;
  for (WlcExpansion e :
       {WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4, WlcExpansion::full}) {
    const IsotropicMembraneLaw law = make_membrane_law(fx.p, fx.s, e);
    const WlcDensity w = fx.w(e);
    std::vector<Eigen::Matrix2d> Fs = sample_deformations();
    Eigen::Matrix2d near_lmax;  // largest stretch 0.97 of the divergence 1/x0
    near_lmax << 0.97 / w.x0, 0.0, 0.0, 1.0;
    Fs.push_back(near_lmax);
    for (const Eigen::Matrix2d& F : Fs) {
      const Invariants I = invariants(F);
      const double avg = average_over_angle(
          [&](double phi) { return lattice_density(w, fx.C(), fx.s, F, phi); }, kPi / 3.0, 1e-13);
      EXPECT_NEAR(law.evaluate(I.i1, I.i2).psi / avg, 1.0, 1e-11) << law.name << "\nF =\n" << F;
    }
  }
}

TEST(InvariantLaws, SecondOrderLawIsTheUnaveragedIsotropicLatticeDensity) {
  const LawFixture fx;
  const WlcDensity w2 = fx.w(WlcExpansion::order2);
  const IsotropicMembraneLaw law = make_membrane_law(fx.p, fx.s, WlcExpansion::order2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(0.0, 2 * kPi);
  for (const Eigen::Matrix2d& F : sample_deformations()) {
    const double psi = lattice_density(w2, fx.C(), fx.s, F);
    const Invariants I = invariants(F);
    EXPECT_NEAR(law.evaluate(I.i1, I.i2).psi / psi, 1.0, 1e-13);
    for (int k = 0; k < 5; ++k) {  // isotropy: F -> F R for any rotation R
      const double t = angle(rng);
      EXPECT_NEAR(lattice_density(w2, fx.C(), fx.s, F * rotation(t)) / psi, 1.0, 1e-13);
      EXPECT_NEAR(lattice_density(w2, fx.C(), fx.s, rotation(t) * F) / psi, 1.0, 1e-13);
    }
  }
}

TEST(LatticeDensity, HigherOrdersHaveSixtyDegreeSymmetryButAreNotIsotropic) {
  const LawFixture fx;
  Eigen::Matrix2d F;
  F << 2.2, 0.3, 0.1, 0.9;
  for (WlcExpansion e : {WlcExpansion::order3, WlcExpansion::order4, WlcExpansion::full}) {
    const WlcDensity w = fx.w(e);
    const double psi = lattice_density(w, fx.C(), fx.s, F);
    for (int k = 1; k < 6; ++k)
      EXPECT_NEAR(lattice_density(w, fx.C(), fx.s, F * rotation(k * kPi / 3)) / psi, 1.0, 1e-13)
          << to_string(e) << " rotation by " << 60 * k << " degrees";
    double spread = 0.0;
    for (double t : {0.1, 0.3, kPi / 6, 0.7})
      spread =
          std::max(spread, std::abs(lattice_density(w, fx.C(), fx.s, F * rotation(t)) / psi - 1.0));
    EXPECT_GT(spread, 1e-4) << to_string(e) << " should depend on the lattice orientation";
  }
}

// Central differences of f at step h and h/2 against the analytic value: the error must
// be small and shrink at second order (ratio ~4) unless already at round-off.
void expect_second_order(const std::function<double(double)>& f, double analytic, double h,
                         double scale, const std::string& what) {
  auto err = [&](double step) { return std::abs((f(step) - f(-step)) / (2 * step) - analytic); };
  const double e1 = err(h), e2 = err(h / 2);
  EXPECT_LT(e1, 1e-5 * scale) << what;
  if (e1 > 1e-10 * scale) {
    EXPECT_GT(e1 / e2, 3.0) << what << " (errors " << e1 << ", " << e2 << ")";
  }
}

TEST(InvariantLaws, AllDerivativesPassFiniteDifferences) {
  const LawFixture fx;
  for (WlcExpansion e :
       {WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4, WlcExpansion::full}) {
    const IsotropicMembraneLaw law = make_membrane_law(fx.p, fx.s, e);
    for (const Eigen::Matrix2d& F : sample_deformations()) {
      const Invariants I = invariants(F);
      if (std::abs(F(0, 0) - F(1, 1)) < 1e-12) continue;
      const InvariantDerivatives d = law.evaluate(I.i1, I.i2);
      const double scale = 1.0 + std::abs(d.d1) + std::abs(d.d2) + std::abs(d.d11) +
                           std::abs(d.d12) + std::abs(d.d22);
      const double h = 1e-3 * std::min(1.0, 0.1 + std::abs(I.i1));
      auto at1 = [&](double s) { return law.evaluate(I.i1 + s, I.i2); };
      auto at2 = [&](double s) { return law.evaluate(I.i1, I.i2 + s); };
      const std::string tag = law.name;
      expect_second_order([&](double s) { return at1(s).psi; }, d.d1, h, scale, tag + " d1");
      expect_second_order([&](double s) { return at2(s).psi; }, d.d2, h, scale, tag + " d2");
      expect_second_order([&](double s) { return at1(s).d1; }, d.d11, h, scale, tag + " d11");
      expect_second_order([&](double s) { return at2(s).d1; }, d.d12, h, scale, tag + " d12");
      expect_second_order([&](double s) { return at1(s).d2; }, d.d12, h, scale, tag + " d21");
      expect_second_order([&](double s) { return at2(s).d2; }, d.d22, h, scale, tag + " d22");
    }
  }
}

// Along F(s) = F0 + s D: Psi' = d1 I1' + d2 I2', Psi'' = d1 I1'' + d2 I2'' + d11 I1'^2
// + 2 d12 I1' I2' + d22 I2'^2 with I1' = cof(F0):D, I1'' = 2 det D, I2' = 2 F0:D, I2'' = 2|D|^2.
// Realisable paths only, so this also covers the isotropic state F0 = l I (b = 0).
TEST(InvariantLaws, DerivativesAlongDeformationPathsIncludingTheIsotropicState) {
  const LawFixture fx;
  Eigen::Matrix2d D1, D2;
  D1 << 1.0, 0.0, 0.0, -1.0;
  D2 << 0.3, 1.0, 0.2, -0.5;
  for (WlcExpansion e : {WlcExpansion::order3, WlcExpansion::order4, WlcExpansion::full}) {
    const IsotropicMembraneLaw law = make_membrane_law(fx.p, fx.s, e);
    for (double lambda : {1.0, 1.4, 0.85}) {
      const Eigen::Matrix2d F0 = lambda * Eigen::Matrix2d::Identity();
      for (const Eigen::Matrix2d& D : {D1, D2}) {
        auto psi = [&](double s) {
          const Invariants I = invariants(F0 + s * D);
          return law.evaluate(I.i1, I.i2);
        };
        const InvariantDerivatives d = psi(0.0);
        const double c1 =
            F0(0, 0) * D(1, 1) + F0(1, 1) * D(0, 0) - F0(0, 1) * D(1, 0) - F0(1, 0) * D(0, 1);
        const double i1p = c1, i1pp = 2 * D.determinant();
        const double i2p = 2 * (F0.array() * D.array()).sum(), i2pp = 2 * D.squaredNorm();
        const double first = d.d1 * i1p + d.d2 * i2p;
        const double second = d.d1 * i1pp + d.d2 * i2pp + d.d11 * i1p * i1p +
                              2 * d.d12 * i1p * i2p + d.d22 * i2p * i2p;
        ASSERT_TRUE(std::isfinite(second)) << law.name;
        const double scale = 1.0 + std::abs(second);
        expect_second_order([&](double s) { return psi(s).psi; }, first, 1e-3, scale,
                            law.name + " path first derivative");
        auto dpsi = [&](double s) {
          const InvariantDerivatives q = psi(s);
          const Eigen::Matrix2d F = F0 + s * D;
          return (first_piola(F, q).array() * D.array()).sum();
        };
        expect_second_order(dpsi, second, 1e-3, scale, law.name + " path second derivative");
      }
    }
  }
}

TEST(LatticeDensity, GradientPassesFiniteDifferences) {
  const LawFixture fx;
  for (WlcExpansion e :
       {WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4, WlcExpansion::full}) {
    const WlcDensity w = fx.w(e);
    for (const Eigen::Matrix2d& F : sample_deformations()) {
      Eigen::Matrix2d g;
      const double psi = lattice_density(w, fx.C(), fx.s, F, 0.2, &g);
      ASSERT_TRUE(std::isfinite(psi));
      for (int k = 0; k < 4; ++k) {
        Eigen::Matrix2d E = Eigen::Matrix2d::Zero();
        E(k / 2, k % 2) = 1.0;
        expect_second_order(
            [&](double s) { return lattice_density(w, fx.C(), fx.s, F + s * E, 0.2); },
            g(k / 2, k % 2), 1e-4, 1.0 + g.cwiseAbs().maxCoeff(),
            to_string(e) + " dPsi/dF entry " + std::to_string(k));
      }
    }
  }
}

TEST(InvariantLaws, InfiniteOutsideTheDomain) {
  const LawFixture fx;
  const WlcDensity w = fx.w(WlcExpansion::full);
  const IsotropicMembraneLaw full = make_membrane_law(fx.p, fx.s, WlcExpansion::full);
  for (WlcExpansion e : {WlcExpansion::order2, WlcExpansion::order4, WlcExpansion::full}) {
    const IsotropicMembraneLaw law = make_membrane_law(fx.p, fx.s, e);
    EXPECT_TRUE(std::isinf(law.evaluate(-1.0, 0.0).psi)) << law.name;  // J = 0
    EXPECT_TRUE(std::isinf(law.evaluate(-1.5, 1.0).psi)) << law.name;  // J < 0
  }
  auto at = [&](double l1) {
    Eigen::Matrix2d F;
    F << l1, 0.0, 0.0, 1.0;
    const Invariants I = invariants(F);
    return full.evaluate(I.i1, I.i2).psi;
  };
  EXPECT_TRUE(std::isfinite(at(0.999 / w.x0)));
  EXPECT_TRUE(std::isinf(at(1.0001 / w.x0)));
  EXPECT_GT(at(0.999 / w.x0), 10 * at(0.9 / w.x0));  // diverges on approach
  Eigen::Matrix2d F;
  F << 1.0, 0.0, 0.0, -1.0;
  EXPECT_TRUE(std::isinf(lattice_density(w, fx.C(), fx.s, F)));
}

}  // namespace
}  // namespace rbc
