// SPDX-License-Identifier: GPL-3.0-or-later
// Closed-form moduli (MODEL.md section 3, paper Sec. 4.3) and the density's higher
// derivatives: reference numbers, an independent formula, and finite differences.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "homogenise/density_derivatives.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/moduli.hpp"

#include "homogenise_parameter_sets.hpp"

namespace rbc {
namespace {

using testing::parameter_sets;

TEST(ClosedForms, DefaultsReproduceModelReferenceNumbers) {
  const LinearModuli m = closed_form_moduli(WlcParameters{}, StericParameters{});
  // MODEL.md: mu = 8.299 uN/m, K = 16.52 uN/m (paper prints 16.6), Poisson 0.331.
  EXPECT_NEAR(m.mu_pN_per_um, 8.299, 0.0005);
  EXPECT_NEAR(m.K_pN_per_um, 16.52, 0.005);
  EXPECT_NEAR(m.poisson(), 0.331, 0.0005);
  EXPECT_NEAR(m.young_pN_per_um(),
              4 * m.K_pN_per_um * m.mu_pN_per_um / (m.K_pN_per_um + m.mu_pN_per_um), 1e-12);
}

TEST(ClosedForms, AgreeWithThePapersExplicitFormulas) {
  for (const auto& [p, s] : parameter_sets()) {
    const LinearModuli a = closed_form_moduli(p, s), b = paper_explicit_moduli(p, s);
    EXPECT_NEAR(a.mu_pN_per_um / b.mu_pN_per_um, 1.0, 1e-12);
    EXPECT_NEAR(a.K_pN_per_um / b.K_pN_per_um, 1.0, 1e-12);
  }
}

TEST(ClosedForms, EveryLawHasTheClosedFormModuli) {
  for (const auto& [p, s] : parameter_sets()) {
    const LinearModuli ref = closed_form_moduli(p, s);
    for (WlcExpansion e :
         {WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4, WlcExpansion::full}) {
      const LinearModuli m = law_moduli(make_membrane_law(p, s, e));
      EXPECT_NEAR(m.mu_pN_per_um / ref.mu_pN_per_um, 1.0, 1e-12) << to_string(e);
      EXPECT_NEAR(m.K_pN_per_um / ref.K_pN_per_um, 1.0, 1e-12) << to_string(e);
      // Stress-free at rest: pure dilation I2 = 2 I1 costs nothing at first order.
      const InvariantDerivatives d = make_membrane_law(p, s, e).evaluate(0.0, 0.0);
      EXPECT_NEAR(d.d1 + 2 * d.d2, 0.0, 1e-12 * ref.K_pN_per_um) << to_string(e);
    }
  }
}

TEST(ClosedForms, InvalidParametersAreRejected) {
  EXPECT_THROW(closed_form_moduli(WlcParameters{0.075, 0.07, 0.0075, 300}, StericParameters{}),
               std::invalid_argument);
  EXPECT_THROW(closed_form_moduli(WlcParameters{}, StericParameters{11.0, 0.005}),
               std::invalid_argument);
  EXPECT_THROW(closed_form_moduli(WlcParameters{}, StericParameters{1.0, 0.0}),
               std::invalid_argument);
  EXPECT_THROW(paper_explicit_moduli(WlcParameters{0.075, 0.2, -1, 300}, StericParameters{}),
               std::invalid_argument);
}

TEST(DensityDerivatives, MatchDiscreteEvaluateAndExactTaylorData) {
  for (WlcExpansion e :
       {WlcExpansion::full, WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4}) {
    const WlcDensity w = make_wlc_density(WlcParameters{}, e);
    for (double z : {0.3, 1.0, 2.5, 8.0}) {
      const auto d = density_derivatives(w, z);
      const DensityValue v = evaluate(w, z);
      EXPECT_NEAR(d[0], v.v, 1e-12 * std::abs(v.v));
      EXPECT_NEAR(d[1], v.dv, 1e-12 * std::abs(v.dv) + 1e-14);
      EXPECT_NEAR(d[2], v.d2v, 1e-12 * std::abs(v.d2v) + 1e-14);
      // The same law from the stretch L/Lbar = sqrt(z) (the energy loops' entry point).
      const DensityValue s = evaluate_stretch(w, std::sqrt(z));
      EXPECT_NEAR(d[0], s.v, 1e-12 * std::abs(s.v));
      EXPECT_NEAR(d[1], s.dv, 1e-12 * std::abs(s.dv) + 1e-14);
      EXPECT_NEAR(d[2], s.d2v, 1e-12 * std::abs(s.d2v) + 1e-14);
    }
    if (e == WlcExpansion::full) {  // at and past Lmax (stretch 1/x0): infeasible
      EXPECT_EQ(evaluate_stretch(w, std::nextafter(1.0 / w.x0, 2.0 / w.x0)).v,
                std::numeric_limits<double>::infinity());
      EXPECT_EQ(evaluate_stretch(w, 1.01 / w.x0).v, std::numeric_limits<double>::infinity());
      // Outside 0 < L < Lmax (the law is evaluated without branches): v = +infinity and both
      // derivatives exactly 0, never a NaN, for every derivative count (and no invalid operation:
      // the trapping build, -DRBC_TRAP_FP=ON, runs this too).
      for (double x : {1.0, 1.5, 0.0, -0.2, std::numeric_limits<double>::infinity()})
        for (int derivatives : {1, 2}) {
          const DensityValue r = detail::evaluate_full(w, x, derivatives);
          EXPECT_EQ(r.v, std::numeric_limits<double>::infinity()) << x;
          EXPECT_EQ(r.dv, 0.0) << x;
          EXPECT_EQ(r.d2v, 0.0) << x;
        }
    }
    // At z = 1 the jets of discrete/wlc.cpp give V''' and V'''' independently.
    const auto d1 = density_derivatives(w, 1.0);
    for (int n = 0; n <= 4; ++n) {
      const bool kept = e == WlcExpansion::full || n <= (e == WlcExpansion::order2   ? 2
                                                         : e == WlcExpansion::order3 ? 3
                                                                                     : 4);
      const double expected = kept ? derivative_at_rest(w, n) : 0.0;
      EXPECT_NEAR(d1[n], expected, 1e-11 * std::abs(derivative_at_rest(w, n))) << n;
    }
  }
  const WlcDensity w = make_wlc_density(WlcParameters{});
  EXPECT_TRUE(std::isinf(density_derivatives(w, 1.000001 / (w.x0 * w.x0))[0]));
  EXPECT_TRUE(std::isinf(density_derivatives(w, 0.0)[0]));
}

TEST(DensityDerivatives, ThirdAndFourthPassFiniteDifferencesAtSecondOrder) {
  const WlcDensity w = make_wlc_density(WlcParameters{});
  for (double z : {0.4, 1.3, 6.0}) {
    const auto d = density_derivatives(w, z);
    for (int n = 3; n <= 4; ++n) {
      auto err = [&](double h) {
        const double fd =
            (density_derivatives(w, z + h)[n - 1] - density_derivatives(w, z - h)[n - 1]) / (2 * h);
        return std::abs(fd - d[n]);
      };
      const double h = 1e-3 * z;
      const double e1 = err(h), e2 = err(h / 2);
      EXPECT_LT(e1, 1e-4 * std::abs(d[n])) << "z " << z << " n " << n;
      EXPECT_GT(e1 / e2, 3.0) << "second-order decay, z " << z << " n " << n;
    }
  }
}

}  // namespace
}  // namespace rbc
