// SPDX-License-Identifier: GPL-3.0-or-later
// The verdicts on the paper's three claims (check_claims) on hand-built inputs whose verdict
// follows from the claim's stated rule: below and above every threshold, one rounding step
// either side of a threshold that no double reaches exactly, exactly at a threshold that one
// does, cost ties, and missing data ("not checked", "not established").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "compare/report.hpp"

namespace rbc {
namespace claims_test {
namespace {

// ---- Claim 1: continuum p = 2 within 2 % (D_A) and 5 % (D_T) of the discrete model, 0-200 pN.

/// A run of `kind` at forces {0, 100, 200, 250} pN. Discrete: D_A = 8 um, D_T = 4 um at every
/// force. Others: 8 qa[k] and 4 qt[k]. The discrete diameters are powers of two, so the
/// ratios the claim compares are qa[k] and qt[k] exactly.
MethodRun claim_run(MethodKind kind, WlcExpansion order, const std::vector<double>& qa = {},
                    const std::vector<double>& qt = {}) {
  MethodRun r;
  r.method = {kind, kind == MethodKind::discrete ? 2000 : 4000, order};
  const double forces[] = {0, 100, 200, 250};
  for (size_t k = 0; k < 4; ++k) {
    CurvePoint p;
    p.force_pN = forces[k];
    p.axial_um = 8.0 * (qa.empty() ? 1.0 : qa[k]);
    p.transverse_um = 4.0 * (qt.empty() ? 1.0 : qt[k]);
    p.converged = true;
    r.points.push_back(p);
  }
  return r;
}

/// The largest double q on the side of `toward` with |q - 1| <= level (q - 1 and 1 - q are
/// exact for q in [0.5, 2]): the last ratio the claim accepts. No q makes |q - 1| equal the
/// double nearest 0.02 or 0.05 exactly (the claim's thresholds), so the boundary is tested
/// one rounding step either side. Found by stepping from 1 +- level, a few steps at most.
double last_accepted_ratio(double level, double toward) {
  double q = toward > 1.0 ? 1.0 + level : 1.0 - level;
  while (std::abs(q - 1.0) > level) q = std::nextafter(q, 1.0);
  while (std::abs(std::nextafter(q, toward) - 1.0) <= level) q = std::nextafter(q, toward);
  return q;
}

ClaimCheck claim_one(const std::vector<MethodRun>& runs) {
  Fig7Result fig7;
  fig7.runs = runs;
  return check_claims(fig7, {}, {}).at(0);
}

TEST(ClaimChecks, OrderTwoAgreementIsNotCheckedWithoutBothModels) {
  EXPECT_EQ(claim_one({}).verdict, "not checked");
  // The continuum at p = 2 is what the claim names: the full law does not stand in for it.
  EXPECT_EQ(claim_one({claim_run(MethodKind::discrete, WlcExpansion::full),
                       claim_run(MethodKind::continuum, WlcExpansion::full)})
                .verdict,
            "not checked");
  EXPECT_EQ(claim_one({claim_run(MethodKind::continuum, WlcExpansion::order2)}).verdict,
            "not checked");
}

TEST(ClaimChecks, OrderTwoAgreementHoldsUpToTheThresholdsAndNotBeyond) {
  const double a_in = last_accepted_ratio(0.02, 2.0), a_out = std::nextafter(a_in, 2.0);
  const double t_in = last_accepted_ratio(0.05, 0.0), t_out = std::nextafter(t_in, 0.0);
  ASSERT_LE(a_in - 1.0, 0.02);
  ASSERT_GT(a_out - 1.0, 0.02);
  ASSERT_LE(1.0 - t_in, 0.05);
  ASSERT_GT(1.0 - t_out, 0.05);
  const MethodRun d = claim_run(MethodKind::discrete, WlcExpansion::full);
  // Methods listed in any order, with another continuum order beside p = 2.
  auto verdict = [&](const std::vector<double>& qa, const std::vector<double>& qt) {
    return claim_one({claim_run(MethodKind::continuum, WlcExpansion::order3, {2, 2, 2, 2}),
                      claim_run(MethodKind::continuum, WlcExpansion::order2, qa, qt), d})
        .verdict;
  };
  const std::string holds = "holds", approx = "holds only approximately";
  // Well inside both thresholds (1 % and 3 %) up to 200 pN; 30 % apart at 250 pN, outside
  // the claim's range.
  EXPECT_EQ(verdict({1.01, 0.99, 1.01, 1.3}, {0.97, 1.03, 0.97, 0.7}), holds);
  // D_A at the last accepted ratio (at 100 pN, either sign of the difference would do), and
  // one step beyond it.
  EXPECT_EQ(verdict({1, a_in, 1, 1}, {1, 1, 1, 1}), holds);
  EXPECT_EQ(verdict({1, a_out, 1, 1}, {1, 1, 1, 1}), approx);
  // D_T likewise, with the difference of the other sign.
  EXPECT_EQ(verdict({1, 1, 1, 1}, {1, t_in, 1, 1}), holds);
  EXPECT_EQ(verdict({1, 1, 1, 1}, {1, t_out, 1, 1}), approx);
  // 200 pN belongs to the range ("up to 200 pN"): a difference just past 2 % there counts.
  EXPECT_EQ(verdict({1, 1, a_in, 1}, {1, 1, 1, 1}), holds);
  EXPECT_EQ(verdict({1, 1, a_out, 1}, {1, 1, 1, 1}), approx);
  // The worst force decides, wherever it lies: 10 % at 100 pN between two exact agreements.
  const ClaimCheck mid = claim_one(
      {d, claim_run(MethodKind::continuum, WlcExpansion::order2, {1, 1.1, 1, 1}, {1, 1, 1, 1})});
  EXPECT_EQ(mid.verdict, approx);
  EXPECT_NE(mid.evidence.find("(at 100.0 pN)"), std::string::npos) << mid.evidence;
}

// ---- Claim 2: above ~200 pN the Taylor orders part from the full law (5 % departure, or a
// link past Lmax), and not below.

StabilityRow order_row(StabilityMetric metric, double parameter_value, std::optional<double> value,
                       StabilityStudy study = StabilityStudy::taylor_order) {
  StabilityRow r;
  r.study = study;
  r.method = "continuum p = 2";
  r.parameter = "departure";
  r.parameter_value = parameter_value;
  r.metric = metric;
  r.value = value;
  return r;
}

std::string claim_two(const std::vector<StabilityRow>& rows) {
  StabilityResult s;
  s.rows = rows;
  return check_claims({}, {}, s).at(1).verdict;
}

TEST(ClaimChecks, FullLawNeededAboveTwoHundredPiconewtons) {
  using M = StabilityMetric;
  const std::string holds = "holds", early = "does not hold as stated (departure below 200 pN)",
                    not_shown = "not shown: the orders stay within 5 % over the whole ladder";
  // No 5 % departure row of the Taylor-order study: not checked, whatever else is there (a
  // 2 % departure, another study's 5 % row, an unphysical force alone).
  EXPECT_EQ(claim_two({}), "not checked");
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.02, 150.0),
                       order_row(M::departure_force_pN, 0.05, 150.0, StabilityStudy::steric),
                       order_row(M::unphysical_from_force_pN, 0, 100.0)}),
            "not checked");
  // Departures above 200 pN, at exactly 200 pN (not below it), and below it.
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, 250.0)}), holds);
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, 200.0)}), holds);
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, 199.0)}), early);
  // One early order decides, whichever comes first.
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, 300.0),
                       order_row(M::departure_force_pN, 0.05, 150.0)}),
            early);
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, 150.0),
                       order_row(M::departure_force_pN, 0.05, 300.0)}),
            early);
  // No order departs on the ladder and none turns unphysical: the parting is not shown.
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, std::nullopt),
                       order_row(M::unphysical_from_force_pN, 0, std::nullopt)}),
            not_shown);
  // Stretching a link past Lmax is parting too: above 200 pN it shows the claim, at exactly
  // 200 pN as well, below 200 pN it contradicts it.
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, std::nullopt),
                       order_row(M::unphysical_from_force_pN, 0, 400.0)}),
            holds);
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, std::nullopt),
                       order_row(M::unphysical_from_force_pN, 0, 200.0)}),
            holds);
  EXPECT_EQ(claim_two({order_row(M::departure_force_pN, 0.05, 300.0),
                       order_row(M::unphysical_from_force_pN, 0, 100.0)}),
            early);
}

// ---- Claim 3 from the accuracy-cost table: the cheapest converged row of each model that
// meets 1 % and 2 % in each of the three force ranges (6 comparisons); costs within a factor
// kAccuracyCostTieRatio are a tie.

AccuracyRow cost_row(MethodKind kind, double cost_eg, double low, double mid, double high,
                     bool converged = true) {
  AccuracyRow r;
  r.method = {kind, kind == MethodKind::discrete ? 1000 : 2000,
              kind == MethodKind::discrete ? WlcExpansion::full : WlcExpansion::order2};
  r.converged = converged;
  r.cost_eg = cost_eg;
  r.error_low = low, r.error_mid = mid, r.error_high = high;
  r.error_all = std::max({low, mid, high});
  return r;
}

std::string claim_three(const std::vector<AccuracyRow>& rows) {
  AccuracyCostTable t;
  t.rows = rows;
  t.reference_relative_sd = 1e-3;
  t.cost_unit_vertices = 1000;
  const std::vector<ClaimCheck> c = check_claims({}, {}, {}, &t);
  EXPECT_EQ(c.size(), 3u);
  return c.at(2).verdict;
}

const MethodKind kD = MethodKind::discrete, kC = MethodKind::continuum;
const std::string kEvery = "holds in every force range at 1 % and 2 %",
                  kMostly = "holds mostly (see the per-range table)",
                  kDiscrete = "does not hold: the discrete model is cheaper",
                  kEqual = "does not hold: about equal cost at equal accuracy";

TEST(ClaimChecks, CheaperAtEqualAccuracyCountsEachForceRangeAndLevel) {
  // The continuum at exactly 1 % in every range (the level is met) costs a tenth of the
  // discrete model: cheaper in all 6 comparisons. Rows that did not converge never count,
  // however cheap and accurate; a dearer, more accurate continuum row is not the cheapest.
  EXPECT_EQ(
      claim_three({cost_row(kD, 1000, 0.005, 0.005, 0.005), cost_row(kC, 100, 0.01, 0.01, 0.01),
                   cost_row(kC, 2000, 0.001, 0.001, 0.001), cost_row(kD, 1, 0, 0, 0, false)}),
      kEvery);
  // The same with the continuum just past 1 %: at 1 % the dear row is the continuum's
  // cheapest (3 discrete wins), at 2 % the cheap one (3 continuum wins).
  EXPECT_EQ(claim_three({cost_row(kD, 1000, 0.005, 0.005, 0.005),
                         cost_row(kC, 100, 0.0101, 0.0101, 0.0101),
                         cost_row(kC, 2000, 0.001, 0.001, 0.001)}),
            kEqual);
  // A cheap discrete row that meets 1 % only at high forces wins the high range at both
  // levels: continuum 4, discrete 2.
  EXPECT_EQ(
      claim_three({cost_row(kD, 1000, 0.005, 0.005, 0.005), cost_row(kC, 100, 0.005, 0.005, 0.005),
                   cost_row(kD, 10, 0.5, 0.5, 0.008)}),
      kMostly);
  // The discrete model cheaper everywhere; with one continuum row close in cost (1.1x) in the
  // low range, those 2 comparisons are ties and the verdict is no longer "discrete cheaper".
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kC, 1000, 0, 0, 0)}), kDiscrete);
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kC, 1000, 0, 0, 0),
                         cost_row(kC, 110, 0.001, 0.5, 0.5)}),
            kEqual);
}

TEST(ClaimChecks, CheaperAtEqualAccuracyTreatsCostsWithinTheTieRatioAsEqual) {
  ASSERT_EQ(kAccuracyCostTieRatio, 1.25);  // the costs below sit on and inside this ratio
  // 125/100 and 100/80 are exactly 1.25 (not a tie); 124/100 is inside it.
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kC, 125, 0, 0, 0)}), kDiscrete);
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kC, 80, 0, 0, 0)}), kEvery);
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kC, 124, 0, 0, 0)}), kEqual);
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kC, 81, 0, 0, 0)}), kEqual);
}

TEST(ClaimChecks, CheaperAtEqualAccuracyIsNotEstablishedWithoutBothModels) {
  const std::string none = "not established";
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kD, 10, 0.001, 0.001, 0.001)}), none);
  EXPECT_EQ(claim_three({cost_row(kC, 100, 0, 0, 0)}), none);
  // Both models present, but neither within 2 % anywhere, or one of them never converged.
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0.03, 0.03, 0.03), cost_row(kC, 10, 0.021, 0.5, 0.5)}),
            none);
  EXPECT_EQ(claim_three({cost_row(kD, 100, 0, 0, 0), cost_row(kC, 10, 0, 0, 0, false)}), none);
}

// ---- Claim 3 without the table: the one-force trade-off study, fastest converged run of each
// model within 1 % or 5 % of the reference D_A.

TradeoffRow trade_row(MethodKind kind, double axial_error_um, double wall_s, bool converged) {
  TradeoffRow r;
  r.run.method = {kind, 1000,
                  kind == MethodKind::discrete ? WlcExpansion::full : WlcExpansion::order2};
  r.axial_error_um = axial_error_um;
  r.wall_s = wall_s;
  r.converged = converged;
  return r;
}

std::string claim_three_from_tradeoff(const std::vector<TradeoffRow>& rows) {
  TradeoffResult t;
  t.force_pN = 88;
  t.reference.axial_um = 8;  // a power of two: 1 % and 5 % of it are 0.08 and 0.4 exactly
  t.rows = rows;
  const std::vector<ClaimCheck> two = check_claims({}, t, {});
  const std::vector<ClaimCheck> four = check_claims({}, t, {}, nullptr);
  EXPECT_EQ(two.size(), 3u);
  EXPECT_EQ(four.size(), 3u);
  EXPECT_EQ(two.at(2).verdict, four.at(2).verdict);  // the short form is the table-less one
  return two.at(2).verdict;
}

TEST(ClaimChecks, CheaperWithoutTheTableNeedsBothModelsWithinTolerance) {
  const std::string ratios = "see ratios", none = "not established at these tolerances";
  EXPECT_EQ(claim_three_from_tradeoff({}), none);
  // The discrete run at exactly 1 %, the continuum at exactly 5 % of the reference: both met.
  EXPECT_EQ(claim_three_from_tradeoff({trade_row(kD, 0.08, 10, true), trade_row(kC, 0.4, 1, true)}),
            ratios);
  // The continuum just past 5 %, or within 1 % but not converged: no continuum run reaches it.
  EXPECT_EQ(claim_three_from_tradeoff(
                {trade_row(kD, 0.08, 10, true), trade_row(kC, std::nextafter(0.4, 1.0), 1, true)}),
            none);
  EXPECT_EQ(claim_three_from_tradeoff({trade_row(kD, 0.0, 10, true), trade_row(kC, 0.0, 1, false)}),
            none);
}

}  // namespace
}  // namespace claims_test
}  // namespace rbc
