// SPDX-License-Identifier: GPL-3.0-or-later
// The Mills data file reader (compare/experiment.hpp): the project's two readings load with the
// documented table, and every kind of bad file is refused naming the file, the row, the column
// and the value (rbc infer --data-file passes user files through it).
#include <gtest/gtest.h>

#include <sstream>
#include <stdexcept>
#include <utility>

#include "compare/experiment.hpp"

namespace rbc {
namespace {

const std::string kHeader = "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n";

std::vector<ExperimentPoint> parse(const std::string& text) {
  std::istringstream in(text);
  return parse_experiment(in, "user.csv");
}

TEST(ExperimentFile, TheProjectsReadingsLoad) {
  const std::pair<const char*, double> files[] = {{"mills2004_optical_tweezers.csv", 193.0},
                                                  {"mills2004_alternative_reading.csv", 192.7}};
  for (const auto& [name, last_force_pN] : files) {
    const auto e = load_experiment(default_data_directory() + "/" + name);
    ASSERT_EQ(e.size(), 13u) << name;
    EXPECT_EQ(e.front().force_pN, 0.0) << name;
    EXPECT_EQ(e.back().force_pN, last_force_pN) << name;
  }
  const auto e = load_experiment(default_data_directory() + "/mills2004_optical_tweezers.csv");
  EXPECT_DOUBLE_EQ(e[1].axial_um, 9.255);  // the 16 pN row, column by column
  EXPECT_DOUBLE_EQ(e[1].axial_err_um, 0.872);
  EXPECT_DOUBLE_EQ(e[1].transverse_um, 6.197);
  EXPECT_DOUBLE_EQ(e[1].transverse_err_um, 0.616);
}

TEST(ExperimentFile, CommentsBlankLinesAndWindowsLineEndsAreRead) {
  const auto e =
      parse("# a comment\r\n" + kHeader + "\r\n0,7.9,0.7,7.9,0.7\r\n16,9.2,0.8,6.2,0.6\r\n");
  ASSERT_EQ(e.size(), 2u);
  EXPECT_DOUBLE_EQ(e[1].transverse_err_um, 0.6);
}

TEST(ExperimentFile, BadFilesAreRefusedNamingWhatIsWrong) {
  struct Case {
    std::string text;
    std::string fragment;
  };
  const Case cases[] = {
      {"force_pN,axial_um,axial_err_um,transverse_um\n0,7.9,0.7,7.9\n", "must have columns"},
      {kHeader + "0,7.9,x,7.9,0.7\n", "'x' is not a number"},
      {kHeader + "0,7.9,0.7\n", "3 values, expected 5"},
      {kHeader, "no data rows"},
      {"", "no header line"},
      {kHeader + "0,nan,0.7,7.9,0.7\n", "row 1: axial_um nan"},
      {kHeader + "0,7.9,0.7,inf,0.7\n", "transverse_um inf"},
      {kHeader + "-1,7.9,0.7,7.9,0.7\n", "force_pN -1 is not finite and >= 0"},
      {kHeader + "0,7.9,-0.1,7.9,0.7\n", "axial_err_um -0.1 is not finite and > 0"},
      {kHeader + "0,7.9,0.7,7.9,0\n", "transverse_err_um 0 is not finite and > 0"},
      {kHeader + "0,0,0.7,7.9,0.7\n", "axial_um 0"},
      {kHeader + "16,9.2,0.8,6.2,0.6\n0,7.9,0.7,7.9,0.7\n", "row 2: force_pN 0 is not above"},
      {kHeader + "16,9.2,0.8,6.2,0.6\n16,9.3,0.8,6.2,0.6\n", "forces must increase"},
  };
  for (const auto& c : cases) {
    try {
      parse(c.text);
      ADD_FAILURE() << "accepted:\n" << c.text;
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("user.csv"), std::string::npos) << m;
      EXPECT_NE(m.find(c.fragment), std::string::npos) << m << "\nexpected: " << c.fragment;
    }
  }
  EXPECT_THROW(load_experiment("/nonexistent/rbc_data.csv"), std::runtime_error);
}

}  // namespace
}  // namespace rbc
