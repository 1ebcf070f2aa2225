// SPDX-License-Identifier: GPL-3.0-or-later
// The Gaussian likelihood of force-diameter data and the checked data parser.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "calibrate/likelihood.hpp"
#include "compare/experiment.hpp"

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

TEST(Likelihood, DefaultReadingUncertaintyComesFromTheTwoMillsReadings) {
  const std::string dir = std::string(RBC_SOURCE_DIR) + "/data/";
  const double r =
      reading_uncertainty_from_readings(load_experiment(dir + "mills2004_optical_tweezers.csv"),
                                        load_experiment(dir + "mills2004_alternative_reading.csv"));
  EXPECT_NEAR(r, kMillsReadingUncertaintyUm, 5e-4);
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

}  // namespace
}  // namespace rbc
