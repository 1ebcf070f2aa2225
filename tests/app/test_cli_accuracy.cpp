// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc stretch --accuracy P%` against the committed trade-off table (data/tradeoff/): each
// refusal exits 2 with one line before any work, and the chosen method's diameters meet P
// against the table's own reference at two forces.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "core/io.hpp"

namespace {
namespace fs = std::filesystem;

struct CliRun {
  int exit_code;
  std::string out, err;  // stdout, stderr
};

CliRun rbc(const std::string& args) {
  // One stderr file per test case: ctest runs the cases of this file as parallel processes.
  const fs::path err_file =
      fs::path(RBC_BINARY_DIR) / "test_output" /
      ("cli_accuracy_stderr_" +
       std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".txt");
  fs::create_directories(err_file.parent_path());
  const std::string cmd =
      std::string(RBC_BINARY_DIR) + "/rbc " + args + " 2>'" + err_file.string() + "'";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 512> buf{};
  while (fgets(buf.data(), buf.size(), p)) out += buf.data();
  const int status = pclose(p);
  std::string err;
  if (FILE* f = fopen(err_file.c_str(), "r")) {
    while (fgets(buf.data(), buf.size(), f)) err += buf.data();
    fclose(f);
  }
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, err};
}

TEST(CliAccuracy, RefusalsExitTwoWithOneLineAndWriteNothing) {
  const fs::path out = fs::path(RBC_BINARY_DIR) / "test_output" / "cli_accuracy_refused";
  fs::remove_all(out);
  struct Case {
    std::string args, expect;
  };
  const Case cases[] = {
      {"--accuracy 1% --model continuum", "cannot be combined with --model"},
      {"--accuracy 1% --vertices 1000", "cannot be combined with --vertices"},
      {"--accuracy 1% --elements 2000", "cannot be combined with --elements"},
      {"--accuracy 1% --order full", "cannot be combined with --order"},
      {"--accuracy 1% --force 38,250", "250 pN lies outside"},
      {"--accuracy 0.001%", "no method"},
      {"--accuracy abc", "expected a finite percentage"},
      {"--accuracy nan", "expected a finite percentage"},
      {"--accuracy inf%", "expected a finite percentage"},
      {"--accuracy -1%", "expected a finite percentage"},
      {"--accuracy 0", "expected a finite percentage"},
  };
  for (const auto& c : cases) {
    const CliRun r = rbc("stretch " + c.args + " --out '" + out.string() + "' -q");
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find("rbc: error: "), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(r.out.empty()) << c.args;
    EXPECT_FALSE(fs::exists(out)) << c.args;
  }
}

/// The table's reference diameters (um) at a force (pN).
std::pair<double, double> reference_at(double force_pN) {
  const rbc::CsvTable t =
      rbc::read_csv(std::string(RBC_SOURCE_DIR) + "/data/tradeoff/reference.csv");
  for (const auto& r : t.rows)
    if (r[0] == force_pN) return {r[1], r[3]};
  ADD_FAILURE() << "no reference at " << force_pN << " pN";
  return {0, 0};
}

TEST(CliAccuracy, WarnsWhenThePhysicsDiffersFromTheTables) {
  const CliRun r = rbc("stretch --accuracy 5% --force 0 --kappa 3e-19 --json -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("rbc: warning: --accuracy"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--kappa"), std::string::npos) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out).at("points");
  EXPECT_TRUE(j[0]["accuracy_choice"].contains("warning"));
}

TEST(CliAccuracy, ChosenMethodMeetsTheAccuracyAtTwoForces) {
  const double percent = 2.0;
  const CliRun r = rbc("stretch --accuracy 2% --force 38,130 --json -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // What was chosen and why: on stderr and in every JSON point.
  EXPECT_NE(r.err.find("--accuracy 2%: chose "), std::string::npos) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out).at("points");
  ASSERT_EQ(j.size(), 2u);
  const auto& choice = j[0]["accuracy_choice"];
  EXPECT_EQ(choice["requested_percent"].get<double>(), percent);
  EXPECT_LE(choice["chosen"]["error_percent"].get<double>() +
                choice["reference_uncertainty_percent"].get<double>(),
            percent);
  EXPECT_TRUE(choice.contains("runner_up"));
  EXPECT_LE(choice["chosen"]["cost_eg"].get<double>(),
            choice["runner_up"]["cost_eg"].get<double>());
  // The table's cheapest entry may be a mirror row: then the run takes that solver path.
  const bool mirror = choice["chosen"]["symmetry"].get<std::string>() == "mirror";
  for (const auto& p : j) {
    const auto [axial, transverse] = reference_at(p["force_pN"].get<double>());
    EXPECT_TRUE(p["converged"].get<bool>());
    if (mirror) {
      EXPECT_GT(p["symmetry_order"].get<int>(), 1) << p;
    }
    EXPECT_LE(std::abs(p["axial_um"].get<double>() - axial) / axial, percent / 100) << p;
    EXPECT_LE(std::abs(p["transverse_um"].get<double>() - transverse) / transverse, percent / 100)
        << p;
  }
}

TEST(CliAccuracy, AnExplicitSymmetryRestrictsTheChoiceToItsRows) {
  for (const std::string symmetry : {"none", "mirror"}) {
    const CliRun r = rbc("stretch --accuracy 2% --force 38 --symmetry " + symmetry + " --json -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out).at("points");
    const auto& choice = j[0]["accuracy_choice"];
    EXPECT_EQ(choice["chosen"]["symmetry"].get<std::string>(), symmetry) << choice;
    if (choice.contains("runner_up")) {
      EXPECT_EQ(choice["runner_up"]["symmetry"].get<std::string>(), symmetry) << choice;
    }
  }
}

}  // namespace
