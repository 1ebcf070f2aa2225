// SPDX-License-Identifier: GPL-3.0-or-later
// The recovery likelihood (calibrate/recovery_likelihood.hpp): the data reader, the time
// rescaling of the continuum release scene against a direct run, the analytic eta_m derivative,
// and the recovery of a synthetic truth.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "calibrate/recovery_likelihood.hpp"
#include "compare/experiment.hpp"
#include "invalid_parameter.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

std::string write_file(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// Both bundled files: the four cells (25 points each) and the single-cell file, which is cell 1
// of the other to its fewer digits.
TEST(RecoveryData, ReadsTheFourCellsAndTheSingleCellFile) {
  const RecoveryData four =
      read_recovery_data(default_data_directory() + "/hochmuth1979_recovery_cells.csv");
  ASSERT_EQ(four.cells.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(four.cells[k].id, k + 1);
    EXPECT_EQ(four.cells[k].time_s.size(), 25u);
  }
  EXPECT_EQ(four.points(), 100);
  EXPECT_DOUBLE_EQ(four.cells[0].time_s[0], 0.00055);
  EXPECT_DOUBLE_EQ(four.cells[0].length_over_width[0], 2.0045);
  EXPECT_DOUBLE_EQ(four.sigma_ratio, 0.02);
  EXPECT_EQ(four.content_hash.size(), 16u);
  const RecoveryData one =
      read_recovery_data(default_data_directory() + "/hochmuth1979_recovery.csv");
  ASSERT_EQ(one.cells.size(), 1u);
  EXPECT_EQ(one.cells[0].id, 1);
  ASSERT_GE(one.cells[0].time_s.size(), 3u);
  for (size_t i = 0; i < std::min<size_t>(one.cells[0].time_s.size(), 25); ++i) {
    EXPECT_NEAR(one.cells[0].time_s[i], four.cells[0].time_s[i], 1e-3);
    EXPECT_NEAR(one.cells[0].length_over_width[i], four.cells[0].length_over_width[i], 1e-3);
  }
  EXPECT_NE(one.content_hash, four.content_hash);
}

// A corrupt file is refused with rbc::InvalidParameter naming the file and the line.
TEST(RecoveryData, CorruptFilesAreRefusedNamingTheLine) {
  const std::string dir = testing::fresh_output_dir("recovery_data_corrupt").string();
  const std::string head = "# comment\ncell,time_s,length_over_width\n1,0.0,2.0\n1,0.1,1.5\n";
  struct Case {
    std::string name, body, expect;
  };
  const std::vector<Case> cases = {
      {"text.csv", head + "1,0.2,abc\n", "line 5 must be a finite number, got 'abc'"},
      {"short.csv", head + "1,0.2\n", "line 5 must be 3 comma-separated numbers"},
      {"time.csv", head + "1,0.05,1.4\n", "line 5 time_s must be greater than"},
      {"ratio.csv", head + "1,0.2,-1\n", "line 5 length_over_width must be > 0"},
      {"cell.csv", head + "1.5,0.2,1.4\n", "line 5 cell must be a positive integer"},
      {"split.csv", head + "1,0.2,1.4\n2,0,2\n2,0.1,1.9\n2,0.2,1.8\n1,0.3,1.3\n",
       "line 9 cell must be the rows of each cell together"},
      {"header.csv", "# c\ntime,ratio\n0,2\n", "line 2 must be the header"},
      {"few.csv", "time_s,length_over_width\n0,2\n0.1,1.5\n", "cell 1 must be at least 3 points"},
      {"nan.csv", head + "1,nan,1.4\n", "line 5 must be a finite number, got 'nan'"},
  };
  for (const Case& c : cases) {
    const std::string path = write_file(dir, c.name, c.body);
    const std::string msg = testing::limit_refusal([&] { read_recovery_data(path); });
    EXPECT_NE(msg.find("recovery data file '" + path + "'"), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.expect), std::string::npos) << c.name << ": " << msg;
  }
  const std::string missing = dir + "/missing.csv";
  EXPECT_NE(testing::limit_refusal([&] { read_recovery_data(missing); }).find("readable"),
            std::string::npos);
}

}  // namespace
}  // namespace rbc
