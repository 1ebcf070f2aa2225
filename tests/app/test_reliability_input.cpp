// SPDX-License-Identifier: GPL-3.0-or-later
// The reliability audit's input cases (shared/reliability/cases.md), one test each:
// bad input is refused up front with exit 2 and one line "rbc: error: <option> <value>: ...",
// before any work (each refusal takes well under a second) and without writing anything.
// Every command runs in its own empty working directory, as the audit ran them.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {
namespace fs = std::filesystem;

struct Result {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

/// Every file under dir with its size (what a run may not change).
std::map<std::string, std::uintmax_t> listing(const fs::path& dir) {
  std::map<std::string, std::uintmax_t> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    files[fs::relative(e.path(), dir).string()] = e.is_regular_file() ? e.file_size() : 0;
  return files;
}

/// A fresh working directory for one case; with_out: it holds out/keep.txt, as in the audit.
class Case {
 public:
  explicit Case(const std::string& name, bool with_out = false)
      : base_(fs::path(RBC_BINARY_DIR) / "test_output" / "reliability" / name),
        work_(base_ / "work") {
    fs::remove_all(base_);
    fs::create_directories(work_);
    if (with_out) {
      fs::create_directories(work_ / "out");
      std::ofstream(work_ / "out" / "keep.txt") << "a file the user keeps\n";
    }
    before_ = listing(work_);
  }
  const fs::path& work() const { return work_; }

  /// Runs `rbc args` in the working directory (time-limited, so a regression cannot hang CI).
  Result run(const std::string& args) const {
    const fs::path out = base_ / "stdout.txt", err = base_ / "stderr.txt";
    const std::string cmd = "cd '" + work_.string() + "' && timeout 60 " +
                            std::string(RBC_BINARY_DIR) + "/rbc " + args + " >'" + out.string() +
                            "' 2>'" + err.string() + "'";
    const int status = std::system(cmd.c_str());
    Result r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
  }

  /// The contract for bad input: exit 2, nothing on stdout, one stderr line
  /// "rbc: error: ..." containing every fragment, and the working directory unchanged.
  void expect_refused(const std::string& args, const std::vector<std::string>& fragments) const {
    const Result r = run(args);
    SCOPED_TRACE("rbc " + args + "\nstderr: " + r.err);
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("rbc: error: ", 0), 0u);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1);
    for (const auto& f : fragments) EXPECT_NE(r.err.find(f), std::string::npos) << f;
    EXPECT_EQ(listing(work_), before_) << "the run wrote or removed files";
  }

 private:
  fs::path base_, work_;
  std::map<std::string, std::uintmax_t> before_;
};

// Case 1: Google Benchmark's own errors read like every other command's.
TEST(ReliabilityInput, Case01BenchErrorsStartLikeEveryCommand) {
  Case c("case01");
  c.expect_refused("bench stretch --benchmark_bogus", {"--benchmark_bogus"});
  c.expect_refused("bench stretch --bogus", {"--bogus"});
}

// Cases 2-6: a non-empty --out is refused unless --force-overwrite.
TEST(ReliabilityInput, Case02MeshRefusesNonEmptyOut) {
  Case("case02", true).expect_refused("mesh --vertices 300 --out out", {"--out out", "not empty"});
}
TEST(ReliabilityInput, Case03StretchRefusesNonEmptyOut) {
  Case("case03", true)
      .expect_refused("stretch --vertices 300 --force 16 --out out", {"--out out", "not empty"});
}
TEST(ReliabilityInput, Case04McRefusesNonEmptyOut) {
  Case("case04", true)
      .expect_refused("mc --vertices 300 --sweeps 20 --out out", {"--out out", "not empty"});
}
TEST(ReliabilityInput, Case05RelaxRefusesNonEmptyOut) {
  Case("case05", true).expect_refused("relax --elements 500 --out out", {"--out out", "not empty"});
}
TEST(ReliabilityInput, Case06ContinuumStretchRefusesNonEmptyOut) {
  Case("case06", true)
      .expect_refused("stretch --model continuum --elements 500 --force 16 --out out",
                      {"--out out", "not empty"});
}

// --out may hold the run being resumed (and only that, without --force-overwrite).
TEST(ReliabilityInput, McResumeMayWriteIntoItsOwnOut) {
  Case c("mc_resume_out");
  const Result first = c.run("mc -n 150 --sweeps 10 -q --json --checkpoint o/c.h5 --out o");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const Result resumed = c.run("mc --sweeps 20 -q --json --resume o/c.h5 --out o");
  EXPECT_EQ(resumed.exit_code, 0) << resumed.err;
  const Result fresh = c.run("mc -n 150 --sweeps 10 -q --out o");
  EXPECT_EQ(fresh.exit_code, 2) << fresh.err;
  EXPECT_NE(fresh.err.find("--out o"), std::string::npos) << fresh.err;
}

// Cases 7-10: forces above each model's documented maximum (discrete 500 pN, continuum 400 pN).
TEST(ReliabilityInput, Case07HugeForceIsRefused) {
  Case("case07").expect_refused("stretch --vertices 300 --force 1e308 --json",
                                {"--force 1e+308", "[0, 500] pN"});
}
TEST(ReliabilityInput, Case08DiscreteForceAboveItsMaximumIsRefused) {
  Case("case08").expect_refused("stretch --model discrete --vertices 300 --force 1e6 --json",
                                {"--force 1e+06", "discrete", "[0, 500] pN"});
}
TEST(ReliabilityInput, Case09ContinuumForce2000IsRefused) {
  Case("case09").expect_refused("stretch --model continuum --elements 500 --force 2000 --json",
                                {"--force 2000", "continuum", "[0, 400] pN"});
}
TEST(ReliabilityInput, Case10ContinuumForce5000IsRefused) {
  Case("case10").expect_refused("stretch --model continuum --elements 500 --force 0,16,5000 --json",
                                {"--force 5000", "continuum", "[0, 400] pN"});
}

// Cases 11-15: non-finite physical parameters.
TEST(ReliabilityInput, Case11InfiniteTemperature) {
  Case("case11").expect_refused("stretch --vertices 300 --force 16 --temperature inf --json",
                                {"--temperature inf", "temperature must be finite", "K"});
}
TEST(ReliabilityInput, Case12InfiniteEta) {
  Case("case12").expect_refused("stretch --vertices 300 --force 16 --eta inf --json",
                                {"--eta inf", "(0, 1]"});
}
TEST(ReliabilityInput, Case13InfiniteLmax) {
  Case("case13").expect_refused("stretch --vertices 300 --force 16 --lmax inf --json",
                                {"--lmax inf", "nm"});
}
TEST(ReliabilityInput, Case14InfinitePersistence) {
  Case("case14").expect_refused("stretch --vertices 300 --force 16 --persistence inf --json",
                                {"--persistence inf", "persistence length must be finite", "nm"});
}
TEST(ReliabilityInput, Case15ContinuumInfiniteTemperature) {
  Case("case15").expect_refused(
      "stretch --model continuum --elements 500 --force 16 --temperature inf --json",
      {"--temperature inf"});
}

// Cases 16-19: the homogenisation commands.
TEST(ReliabilityInput, Case16ModuliInfiniteTemperature) {
  Case("case16").expect_refused("moduli --temperature inf --json", {"--temperature inf"});
}
TEST(ReliabilityInput, Case17ModuliInfiniteEta) {
  Case("case17").expect_refused("moduli --eta inf --json", {"--eta inf"});
}
TEST(ReliabilityInput, Case18ModuliInfiniteLmax) {
  Case("case18").expect_refused("moduli --lmax inf --json", {"--lmax inf"});
}
TEST(ReliabilityInput, Case19PsiInfiniteTemperatureWritesNothing) {
  Case("case19").expect_refused("psi --temperature inf --out a.csv", {"--temperature inf"});
}

// Cases 20-21: solver budgets.
TEST(ReliabilityInput, Case20InfiniteTolerance) {
  Case("case20").expect_refused("stretch --vertices 300 --force 16 --tolerance inf --json",
                                {"--tolerance inf", "(0, 10] pN"});
}
TEST(ReliabilityInput, Case21NegativeIterationBudget) {
  Case("case21").expect_refused("stretch --vertices 300 --force 16 --max-iterations -5 --json",
                                {"--max-iterations -5", "[1, 10000000]"});
}

// Case 22: a deformation outside the full WLC's domain (principal stretch >= Lmax/Lbar).
TEST(ReliabilityInput, Case22DeformationOutsideTheWlcDomain) {
  Case c("case22");
  c.expect_refused("psi --deformation 10,0,0,1", {"--deformation 10,0,0,1", "3.17"});
  // Inside the domain the same command answers with finite numbers.
  const Result ok = c.run("psi --deformation 1.5,0,0,1");
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(ok.out.find("inf"), std::string::npos) << ok.out;
  EXPECT_EQ(ok.out.find("nan"), std::string::npos) << ok.out;
}

// Cases 23-24: spontaneous curvatures far beyond any membrane's.
TEST(ReliabilityInput, Case23RelaxHugeH0) {
  Case("case23").expect_refused("relax --elements 500 --h0 1e308 --json",
                                {"--h0 1e+308", "[-100, 100] 1/um"});
}
TEST(ReliabilityInput, Case24StretchHugeH0) {
  Case("case24").expect_refused("stretch --vertices 300 --force 16 --h0 1e300 --json",
                                {"--h0 1e+300", "[-100, 100] 1/um"});
}

// Cases 25-27: integers without wrap-around or clamping.
TEST(ReliabilityInput, Case25NegativeSeed) {
  Case("case25").expect_refused("mc --vertices 300 --sweeps 20 --seed -5 --json",
                                {"--seed -5", "18446744073709551615"});
}
TEST(ReliabilityInput, Case26SeedBeyond64Bits) {
  Case("case26").expect_refused(
      "mc --vertices 300 --sweeps 20 --seed 99999999999999999999999 --json",
      {"--seed 99999999999999999999999"});
}
TEST(ReliabilityInput, Case27NegativeStreams) {
  Case("case27").expect_refused("mc --vertices 300 --sweeps 20 --streams -1 --json",
                                {"--streams -1", "[0, 1024]"});
}

// Cases 28-29: the force bound holds for the Monte Carlo start and the trade-off study.
TEST(ReliabilityInput, Case28McForceAboveTheMaximum) {
  Case("case28").expect_refused("mc --vertices 300 --force 1e6 --sweeps 20 --json",
                                {"--force 1e+06", "[0, 500] pN"});
}
TEST(ReliabilityInput, Case29TradeoffForceAboveTheMaximum) {
  Case("case29").expect_refused(
      "tradeoff --out o --force 1e6 --vertices 250 --no-continuum --mc-budget 0",
      {"--force 1e+06", "[0, 500] pN"});
}

// Case 30: at 0 K the quench's acceptance cannot exceed 1/2.
TEST(ReliabilityInput, Case30TradeoffAcceptanceAboveOneHalf) {
  Case("case30").expect_refused(
      "tradeoff --out o --vertices 250,500 --no-continuum --mc-vertices 250 --mc-budget 5 "
      "--mc-acceptance 0.9",
      {"--mc-acceptance 0.9", "(0, 0.5)"});
}

// Case 33: forces that differ in the second decimal write distinct shapes; equal forces with
// --out are refused.
TEST(ReliabilityInput, Case33OutputNamesDoNotCollide) {
  Case c("case33");
  const Result r = c.run("stretch --vertices 300 --force 16.01,16.04 -q --out o");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"shape_16.01pN.h5", "shape_16.01pN.xdmf", "shape_16.04pN.h5",
                        "shape_16.04pN.xdmf", "stretch.csv", "run.json"})
    EXPECT_TRUE(fs::exists(c.work() / "o" / f)) << f;
  // The data lines (the comment lines above them record the run's configuration).
  std::istringstream lines(slurp(c.work() / "o" / "stretch.csv"));
  std::string csv;
  for (std::string line; std::getline(lines, line);)
    if (line.rfind('#', 0) != 0) csv += line + "\n";
  ASSERT_NE(csv.find("16.04"), std::string::npos) << csv;
  for (const char* bad : {"nan", "inf", "null"}) EXPECT_EQ(csv.find(bad), std::string::npos) << bad;
  Case("case33_repeat")
      .expect_refused("stretch --vertices 300 --force 16,16 --out o",
                      {"--force 16,16", "distinct"});
}

// Case 34: after progress lines, the non-convergence message still prints the residual and the
// drifts in scientific notation (the progress sink no longer changes std::cerr's format).
TEST(ReliabilityInput, Case34NonConvergenceReportsTheResidualInScientificNotation) {
  Case c("case34");
  const Result r = c.run("stretch --vertices 300 --force 88 --max-iterations 5");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("[ "), std::string::npos) << "expected progress lines:\n" << r.err;
  const std::regex message(
      "rbc: error: force 88 pN did not converge .*residual -?[0-9]\\.[0-9]{3}e"
      "[+-][0-9]+ pN, area drift -?[0-9]\\.[0-9]{3}e[+-][0-9]+, volume "
      "drift -?[0-9]\\.[0-9]{3}e[+-][0-9]+");
  EXPECT_TRUE(std::regex_search(r.err, message)) << r.err;
}

// Case 35: an unwritable --out fails before any computation (no progress line is printed).
TEST(ReliabilityInput, Case35UnwritableOutFailsBeforeComputing) {
  Case c("case35");
  c.expect_refused("fig7 --out /proc/x --method discrete:300", {"--out /proc/x"});
  c.expect_refused("tradeoff --out /proc/x --vertices 250 --no-continuum --mc-budget 0",
                   {"--out /proc/x"});
}

// Choices are checked as such: the message names the option and the value.
TEST(ReliabilityInput, ChoicesNameOptionAndValue) {
  Case c("choices");
  c.expect_refused("stretch --contact nope", {"--contact nope", "area"});
  c.expect_refused("stretch --model continuum --order 7", {"--order 7", "full"});
  c.expect_refused("mc --start nowhere", {"--start nowhere", "equilibrium"});
  c.expect_refused("mesh --quality nope", {"--quality nope", "projected"});
}

// Case 38: the message names the option and the value.
TEST(ReliabilityInput, Case38MessagesNameOptionAndValue) {
  Case c("case38");
  c.expect_refused("stretch --kappa 0", {"--kappa 0", "(0, 1e-16] J"});
  c.expect_refused("relax --max-iterations -1", {"--max-iterations -1", "[1, 10000000]"});
}

}  // namespace
