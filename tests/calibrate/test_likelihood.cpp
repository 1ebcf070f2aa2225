// SPDX-License-Identifier: GPL-3.0-or-later
// The Gaussian likelihood of force-diameter data and the checked data parser.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "calibrate/forward_model.hpp"
#include "calibrate/infer.hpp"
#include "calibrate/likelihood.hpp"
#include "compare/experiment.hpp"
#include "continuum/continuum_stretch.hpp"
#include "core/validation.hpp"
#include "discrete/stretch.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

const char* kHeader = "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n";

std::vector<ExperimentPoint> three_points() {
  return {{0, 8.0, 0.5, 8.0, 0.5}, {20, 9.5, 0.4, 6.5, 0.3}, {50, 11.0, 0.6, 5.5, 0.2}};
}

TEST(Likelihood, ClosedFormWithTheZeroForcePointCountedOnce) {
  const DiameterData d = make_diameter_data(three_points(), 0.3);
  EXPECT_EQ(d.terms(), 5);  // 2 per force, 1 at 0 pN
  EXPECT_DOUBLE_EQ(d.axial_sigma_um[1], std::hypot(0.4, 0.3));
  EXPECT_DOUBLE_EQ(d.smallest_error_bar_um, 0.2);
  ModelDiameters m{{8.2, 9.0, 11.5}, {7.0, 6.4, 5.0}};  // D_T(0) = 7.0 must not count
  double expect = 0;
  auto add = [&](double model, double data, double s) {
    expect += -0.5 * std::pow((model - data) / s, 2) - std::log(std::sqrt(2 * M_PI) * s);
  };
  add(8.2, 8.0, d.axial_sigma_um[0]);
  add(9.0, 9.5, d.axial_sigma_um[1]);
  add(6.4, 6.5, d.transverse_sigma_um[1]);
  add(11.5, 11.0, d.axial_sigma_um[2]);
  add(5.0, 5.5, d.transverse_sigma_um[2]);
  EXPECT_NEAR(gaussian_log_likelihood(d, m, 1.0), expect, 1e-12);
  m.transverse_um[0] = 100.0;
  EXPECT_NEAR(gaussian_log_likelihood(d, m, 1.0), expect, 1e-12);
}

TEST(Likelihood, SigmaScaleMaximisesAtTheRmsStandardisedResidual) {
  // d/dc log L = -terms/c + chi2/c^3 = 0  at  c^2 = chi2 / terms.
  const DiameterData d = make_diameter_data(three_points(), 0.0);
  const ModelDiameters m{{8.9, 9.0, 12.5}, {8.0, 6.0, 5.1}};
  const double chi2 = -2 * (gaussian_log_likelihood(d, m, 1.0) -
                            gaussian_log_likelihood(d, {d.axial_um, d.transverse_um}, 1.0));
  const double c = std::sqrt(chi2 / d.terms());
  const double h = 1e-4 * c;
  const double l0 = gaussian_log_likelihood(d, m, c);
  EXPECT_GT(l0, gaussian_log_likelihood(d, m, c - h));
  EXPECT_GT(l0, gaussian_log_likelihood(d, m, c + h));
  const double slope =
      (gaussian_log_likelihood(d, m, c + h) - gaussian_log_likelihood(d, m, c - h)) / (2 * h);
  EXPECT_NEAR(slope, 0.0, 1e-6 * d.terms() / c);
}

// A user's file without a declared uncertainty: the likelihood's sigmas are its error bars,
// bit for bit (no extra uncertainty is added behind the user's back).
TEST(Likelihood, AFileWithoutDeclarationsGetsExactlyItsOwnErrorBars) {
  const auto dir = testing::fresh_output_dir("calibrate_own_sigma");
  const std::string file = (dir / "mine.csv").string();
  std::ofstream(file) << "# my cells\n"
                      << kHeader << "0,8.0,0.5,8.0,0.5\n20,9.5,0.4,6.5,0.3\n50,11.0,0.6,5.5,0.2\n";
  const DiameterData d = load_diameter_data(file, 0.0, MethodKind::continuum);
  const auto points = three_points();
  ASSERT_EQ(d.size(), 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(d.axial_sigma_um[k], points[k].axial_err_um) << k;
    EXPECT_EQ(d.transverse_sigma_um[k], points[k].transverse_err_um) << k;
  }
  EXPECT_EQ(d.name, "mine.csv");
  EXPECT_EQ(d.declared_extra_uncertainty_um, 0.0);
  EXPECT_EQ(d.added_extra_uncertainty_um, 0.0);
  EXPECT_EQ(InferOptions{}.extra_uncertainty_um, 0.0);  // and none by default
}

// A declared extra uncertainty and one the user adds enter in quadrature with each error bar:
// sigma^2 = err^2 + declared^2 + added^2 (calibrate/likelihood.hpp).
TEST(Likelihood, DeclaredAndAddedUncertaintiesAddInQuadrature) {
  const auto dir = testing::fresh_output_dir("calibrate_declared_sigma");
  const std::string file = (dir / "declared.csv").string();
  std::ofstream(file) << "# name: Lab B\n# extra_uncertainty_um: 0.3\n"
                      << kHeader << "0,8.0,0.5,8.0,0.5\n20,9.5,0.4,6.5,0.3\n50,11.0,0.6,5.5,0.2\n";
  const auto points = three_points();
  const DiameterData declared = load_diameter_data(file, 0.0, MethodKind::continuum);
  EXPECT_EQ(declared.name, "Lab B");
  EXPECT_EQ(declared.declared_extra_uncertainty_um, 0.3);
  const DiameterData both = load_diameter_data(file, 0.4, MethodKind::continuum);
  EXPECT_EQ(both.added_extra_uncertainty_um, 0.4);
  EXPECT_NEAR(both.extra_uncertainty_um(), 0.5, 1e-15);  // 3-4-5
  for (int k = 0; k < 3; ++k) {
    const double ea = points[k].axial_err_um, et = points[k].transverse_err_um;
    EXPECT_NEAR(declared.axial_sigma_um[k], std::sqrt(ea * ea + 0.09), 1e-15) << k;
    EXPECT_NEAR(declared.transverse_sigma_um[k], std::sqrt(et * et + 0.09), 1e-15) << k;
    EXPECT_NEAR(both.axial_sigma_um[k], std::sqrt(ea * ea + 0.09 + 0.16), 1e-15) << k;
    EXPECT_NEAR(both.transverse_sigma_um[k], std::sqrt(et * et + 0.09 + 0.16), 1e-15) << k;
  }
  EXPECT_THROW(load_diameter_data(file, -0.1, MethodKind::continuum), std::invalid_argument);
}

void expect_parse_error(const std::string& body, const std::string& fragment) {
  std::istringstream in(body);
  try {
    parse_experiment(in, "test.csv");
    ADD_FAILURE() << "accepted:\n" << body;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("test.csv"), std::string::npos) << e.what();
  }
}

TEST(ExperimentParser, AcceptsTheMillsFormatAndNamesEveryDefect) {
  std::istringstream good(std::string("# comment\n") + kHeader +
                          "0,7.9,0.7,7.9,0.7\n\n16,9.2,0.8,6.2,0.6\n");
  const auto p = parse_experiment(good, "good");
  ASSERT_EQ(p.size(), 2u);
  EXPECT_DOUBLE_EQ(p[1].transverse_err_um, 0.6);
  expect_parse_error("force_pN,axial_um,axial_err_um,transverse_um\n0,1,1,1\n",
                     "transverse_err_um");  // missing column
  expect_parse_error(std::string(kHeader) + "0,7.9,0.7,abc,0.7\n", "abc");
  expect_parse_error(std::string(kHeader) + "0,7.9,0.7,7.9,0\n", "transverse_err_um 0");
  expect_parse_error(std::string(kHeader) + "0,7.9,-0.2,7.9,0.5\n", "-0.2");
  expect_parse_error(std::string(kHeader) + "20,7.9,0.7,7.9,0.7\n10,8,0.7,7,0.7\n",
                     "force_pN 10 is not above");
  expect_parse_error(std::string(kHeader) + "0,7.9,0.7\n", "3 values");
  expect_parse_error(std::string(kHeader), "no data rows");
  expect_parse_error("", "no header");
}

// The calibration holds the chosen model's documented force maximum (kMaxContinuumForce_pN =
// 400 pN, kMaxDiscreteForce_pN = 500 pN): a data row beyond it is refused when the data are
// read, naming the file, the row and the force, before any forward run; the forward model's own
// options refuse such forces too.
TEST(DataForces, ARowBeyondTheModelsMaximumIsRefusedNamingFileRowAndForce) {
  const std::vector<ExperimentPoint> points = {
      {0, 7.8, 0.3, 7.8, 0.3}, {38, 11.0, 0.5, 6.6, 0.4}, {450, 19.0, 0.8, 4.2, 0.4}};
  EXPECT_NO_THROW(check_data_forces(points, MethodKind::discrete, "d.csv"));
  try {
    check_data_forces(points, MethodKind::continuum, "d.csv");
    ADD_FAILURE() << "a 450 pN row accepted for the continuum model";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "experiment file 'd.csv' data row 3: force (continuum model) must be finite and "
                 "in [0, 400] pN, got 450 pN");
  }

  const auto dir = testing::fresh_output_dir("calibrate_data_forces");
  const std::string file = (dir / "beyond.csv").string();
  std::ofstream(file) << kHeader << "0,7.8,0.3,7.8,0.3\n38,11.0,0.5,6.6,0.4\n1000,20,0.8,4,0.4\n";
  for (MethodKind kind : {MethodKind::continuum, MethodKind::discrete}) {
    try {
      load_diameter_data(file, 0.4, kind);
      ADD_FAILURE() << "a 1000 pN row accepted";
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("'" + file + "' data row 3"), std::string::npos) << what;
      EXPECT_NE(what.find(kind == MethodKind::continuum ? "[0, 400] pN" : "[0, 500] pN"),
                std::string::npos)
          << what;
      EXPECT_NE(what.find("got 1000 pN"), std::string::npos) << what;
    }
  }
  // The whole problem: refused while reading the data, before the forward model exists.
  InferOptions o;
  o.data_file = file;
  o.method = parse_method("continuum:2:200");
  o.parameters = {Parameter::sigma_scale};
  EXPECT_THROW(InferenceProblem{o}, std::invalid_argument);
}

TEST(DataForces, TheForwardModelsOptionsHoldTheSameMaximum) {
  ForwardOptions fo;
  fo.method = parse_method("continuum:2:200");
  fo.forces_pN = {0.0, 38.0, 1000.0};
  EXPECT_THROW(fo.validate(), InvalidParameter);
  EXPECT_THROW(ForwardModel{fo}, InvalidParameter);
  fo.forces_pN = {0.0, 38.0, 400.0};
  EXPECT_NO_THROW(fo.validate());
  fo.method = parse_method("discrete:300");
  fo.forces_pN = {0.0, 500.0};
  EXPECT_NO_THROW(fo.validate());
  fo.forces_pN = {0.0, 800.0};
  EXPECT_THROW(fo.validate(), InvalidParameter);
  EXPECT_EQ(max_method_force_pN(MethodKind::discrete), kMaxDiscreteForce_pN);
  EXPECT_EQ(max_method_force_pN(MethodKind::continuum), kMaxContinuumForce_pN);
}

}  // namespace
}  // namespace rbc
