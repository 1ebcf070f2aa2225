// SPDX-License-Identifier: GPL-3.0-or-later
// The --params and --prior parsers: good input parsed, bad input named.
#include <gtest/gtest.h>

#include "calibrate/prior_spec.hpp"

namespace rbc {
namespace {

void expect_error_naming(const std::string& text, const std::string& fragment) {
  try {
    parse_prior(text);
    ADD_FAILURE() << text << " was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(Prior, ParsesNameAndBox) {
  const PriorRange r = parse_prior("persistence=3:20");
  EXPECT_EQ(r.parameter, Parameter::persistence);
  EXPECT_EQ(r.lower, 3.0);
  EXPECT_EQ(r.upper, 20.0);
  const PriorRange k = parse_prior("kappa=1e-19:5e-19");
  EXPECT_EQ(k.parameter, Parameter::kappa);
  EXPECT_DOUBLE_EQ(k.upper, 5e-19);
}

TEST(Prior, BadBoxesAreNamed) {
  expect_error_naming("persistence=20:3", "persistence=20:3");  // inverted
  expect_error_naming("persistence=3:3", "persistence=3:3");    // empty
  expect_error_naming("persistence=abc:3", "abc");
  expect_error_naming("persistence=3:nan", "nan");
  expect_error_naming("stiffness=1:2", "stiffness");
  expect_error_naming("persistence3:20", "NAME=LOWER:UPPER");
  expect_error_naming("lmax=50:300", "Lbar");
  expect_error_naming("contact-fraction=0.1:0.7", "contact fraction");
  expect_error_naming("sigma-scale=-1:2", "sigma");
}

TEST(Prior, ParameterListsRefuseUnknownAndRepeatedNames) {
  const auto p = parse_parameter_list("persistence,lmax,sigma-scale");
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[2], Parameter::sigma_scale);
  EXPECT_THROW(parse_parameter_list("persistence,bogus"), std::invalid_argument);
  EXPECT_THROW(parse_parameter_list("lmax,lmax"), std::invalid_argument);
  EXPECT_THROW(parse_parameter_list(""), std::invalid_argument);
}

TEST(Prior, DefaultBoxesAreValidAndHoldThePaperValues) {
  // eta-m: Hochmuth et al. 1979's 0.6 pN s/um; tau: a 0.1 um offset (its box starts at 0);
  // eta-spread: 0.2, the sd of log eta_m of the four Hochmuth cells fitted one by one.
  const double paper[kParameterCount] = {7.5, 237.75, 2e-19, 0.05, 1.0, 0.6, 0.1, 0.2};
  for (int k = 0; k < kParameterCount; ++k) {
    const PriorRange r = default_prior(static_cast<Parameter>(k));
    EXPECT_NO_THROW(r.validate());
    EXPECT_LT(r.lower, paper[k]);
    EXPECT_GT(r.upper, paper[k]);
    EXPECT_EQ(parameter_from_string(to_string(r.parameter)), r.parameter);
  }
}

}  // namespace
}  // namespace rbc
