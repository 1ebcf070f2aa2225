// SPDX-License-Identifier: GPL-3.0-or-later
// The stretch-data file reader (compare/experiment.hpp): the project's two data sets load with
// the documented table and their declared names, the header declarations are read or refused,
// and every kind of bad file is refused naming the file, the row, the column and the value (rbc
// infer --data-file passes user files through it).
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

ExperimentFile parse_file(const std::string& text, const std::string& path = "dir/user.csv") {
  std::istringstream in(text);
  return parse_experiment_file(in, path);
}

// The two bundled stretch tables (data/README.md): their rows, and the provenance they declare
// (the attribution of the README and the ~0.1 um agreement of independent digitisations).
TEST(ExperimentFile, TheProjectsDataSetsLoadWithTheirDeclaredNames) {
  struct Bundled {
    const char* file;
    double last_force_pN;
    const char* name;
  };
  const Bundled files[] = {
      {"suresh2005_healthy_optical_tweezers.csv", 193.0,
       "Suresh et al. 2005, Fig. 7a/b, healthy cells"},
      {"mills2004_fig8_optical_tweezers.csv", 192.7, "Mills et al. 2004, Fig. 8"}};
  for (const auto& b : files) {
    const ExperimentFile f = load_experiment_file(default_data_directory() + "/" + b.file);
    ASSERT_EQ(f.points.size(), 13u) << b.file;
    EXPECT_EQ(f.points.front().force_pN, 0.0) << b.file;
    EXPECT_EQ(f.points.back().force_pN, b.last_force_pN) << b.file;
    EXPECT_EQ(f.name, b.name);
    EXPECT_EQ(f.label(), b.name);
    EXPECT_EQ(f.extra_uncertainty_um, 0.1) << b.file;
  }
  const auto e =
      load_experiment(default_data_directory() + "/suresh2005_healthy_optical_tweezers.csv");
  EXPECT_DOUBLE_EQ(e[1].axial_um, 9.255);  // the 16 pN row, column by column
  EXPECT_DOUBLE_EQ(e[1].axial_err_um, 0.872);
  EXPECT_DOUBLE_EQ(e[1].transverse_um, 6.197);
  EXPECT_DOUBLE_EQ(e[1].transverse_err_um, 0.616);
  const auto m = load_experiment(default_data_directory() + "/mills2004_fig8_optical_tweezers.csv");
  EXPECT_DOUBLE_EQ(m[12].axial_um, 15.261);  // the 192.7 pN row
  EXPECT_DOUBLE_EQ(m[12].axial_err_um, 2.348);
}

TEST(ExperimentFile, DeclarationsAreReadAndAFileWithoutThemIsLabelledByItsName) {
  const std::string rows = kHeader + "0,7.9,0.7,7.9,0.7\n16,9.2,0.8,6.2,0.6\n";
  const ExperimentFile plain = parse_file("# my cells, 2024\n# note: lab B\n" + rows);
  EXPECT_EQ(plain.name, "");
  EXPECT_EQ(plain.label(), "user.csv");  // the file name, without its directory
  EXPECT_EQ(plain.extra_uncertainty_um, 0.0);
  ASSERT_EQ(plain.points.size(), 2u);

  const ExperimentFile declared = parse_file(
      "# name:  Lab B, healthy donors  \n# extra_uncertainty_um: 0.25\n# Units: pN, um\n" + rows);
  EXPECT_EQ(declared.name, "Lab B, healthy donors");  // blanks around the value dropped
  EXPECT_EQ(declared.label(), "Lab B, healthy donors");
  EXPECT_EQ(declared.extra_uncertainty_um, 0.25);
  // A declaration after the header counts too (every comment line is read).
  EXPECT_EQ(parse_file(rows + "# extra_uncertainty_um: 1e-1\n").extra_uncertainty_um, 0.1);
}

TEST(ExperimentFile, BadDeclarationsAreRefusedNamingTheFile) {
  const std::string rows = kHeader + "0,7.9,0.7,7.9,0.7\n";
  const std::pair<std::string, std::string> cases[] = {
      {"# extra_uncertainty_um: -0.1\n", "extra_uncertainty_um '-0.1': expected a finite number"},
      {"# extra_uncertainty_um: 0.1 um\n", "'0.1 um'"},
      {"# extra_uncertainty_um: nan\n", "'nan'"},
      {"# extra_uncertainty_um:\n", "''"},
      {"# extra_uncertainty_um: 0.1\n# extra_uncertainty_um: 0.2\n", "twice"},
      {"# name: A\n# name: B\n", "declares 'name' twice"},
      {"# name:\n", "empty 'name'"},
      // A misspelt uncertainty would silently leave the error bars as they are: refused.
      {"# extra_uncertainty: 0.1\n", "'extra_uncertainty', which is not a declaration"},
      {"# reading_uncertainty_um: 0.4\n", "'reading_uncertainty_um'"},
      // Bytes of the file are quoted escaped, so the message stays one printable line.
      {"# extra_uncertainty_um: 0.1\xff\x01\n", "'0.1\\xff\\x01'"},
  };
  for (const auto& [head, fragment] : cases) {
    try {
      parse_file(head + rows);
      ADD_FAILURE() << "accepted:\n" << head;
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("dir/user.csv"), std::string::npos) << m;
      EXPECT_NE(m.find(fragment), std::string::npos) << m << "\nexpected: " << fragment;
    }
  }
}

TEST(ExperimentFile, PlotLabelsFollowTheHouseStyle) {
  EXPECT_EQ(experiment_plot_label("my_cells.csv"), "my\\_cells.csv");
  EXPECT_EQ(experiment_plot_label("O'Brien 2020"), "O’Brien 2020");
  EXPECT_EQ(experiment_plot_label("bars +-0.4 um"), "bars +-0.4 µm");
  EXPECT_EQ(experiment_plot_label("um: 0.4um, (0.2 um)"), "µm: 0.4µm, (0.2 µm)");
  EXPECT_EQ(experiment_plot_label("drums umbra mum"), "drums umbra mum");
  EXPECT_EQ(experiment_plot_label("Mills et al. 2004, Fig. 8"), "Mills et al. 2004, Fig. 8");
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
