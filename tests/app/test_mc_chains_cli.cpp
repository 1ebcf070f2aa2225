// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc mc --chains`: validation (exit 2), the pooled JSON and per-chain series files, results
// identical on one and two threads, a checkpoint of every chain resumed on another thread count
// bit for bit, and the refusals of a checkpoint of another chain count or of the one-chain
// format.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_run.hpp"
#include "core/h5file.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::fresh_output_dir;
using testing::run_rbc;

std::string shell_quoted(const fs::path& p) {
  std::string q = "'";  // (appended: GCC 12's -Wrestrict misfires on "'" + string)
  q += p.string();
  q += '\'';
  return q;
}

std::string data_lines(const fs::path& p) {
  std::ifstream in(p);
  std::string text;
  for (std::string line; std::getline(in, line);)
    if (line.rfind('#', 0) != 0) text += line + "\n";
  return text;
}

/// A shell command (rbc or mpirun ...) with OpenMP at one thread; stdout and stderr apart.
CliRun run_rbc_shell(const std::string& command) {
  const fs::path err = fresh_output_dir("mc_chains_cli_shell_err") / "stderr.txt";
  CliRun r;
  FILE* p = popen(("OMP_NUM_THREADS=1 " + command + " 2> '" + err.string() + "'").c_str(), "r");
  if (!p) return r;
  char buffer[4096];
  for (std::size_t n; (n = fread(buffer, 1, sizeof buffer, p)) > 0;) r.out.append(buffer, n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err);
  r.err.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return r;
}

/// The JSON keys that describe the chains and their statistics (not timings, the thread record,
/// the run record, or the running-total round-off diagnostic).
json chain_fields(const std::string& out) {
  json j = json::parse(out);
  for (const char* k : {"wall_s", "sweeps_per_s", "moves_per_s", "running_total_drift_area_um2",
                        "running_total_drift_volume_um3", "command", "config", "provenance",
                        "threads", "sweeps_this_run", "resume_note"})
    j.erase(k);
  return j;
}

TEST(McChainsCli, ChainCountIsValidatedBeforeAnyWork) {
  for (const char* bad : {"0", "17", "-1", "two"}) {
    const CliRun r = run_rbc(std::string("mc -n 150 --sweeps 10 -q --chains ") + bad);
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.all();
    EXPECT_EQ(r.err.rfind("rbc: error: --chains", 0), 0u) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }
}

TEST(McChainsCli, ThreeChainsArePooledAndIdenticalOnOneAndTwoThreads) {
  const fs::path dir = fresh_output_dir("mc_chains_cli_pooled");
  const std::string args = "mc -n 150 --force 20 --sweeps 40 --seed 4 --chains 3 -q --json ";
  const CliRun one = run_rbc(args + "--no-picture --out " + shell_quoted(dir / "one"), 1),
               two = run_rbc(args + "--no-picture --out " + shell_quoted(dir / "two"), 2);
  ASSERT_EQ(one.exit_code, 0) << one.all();
  ASSERT_EQ(two.exit_code, 0) << two.all();
  const json a = json::parse(one.out), b = json::parse(two.out);
  EXPECT_EQ(a.at("threads").at("used").get<int>(), 1);
  EXPECT_EQ(b.at("threads").at("used").get<int>(), 2);
  EXPECT_EQ(chain_fields(one.out), chain_fields(two.out));
  EXPECT_EQ(a.at("chains").get<int>(), 3);
  ASSERT_EQ(a.at("chain_seeds").size(), 3u);
  EXPECT_EQ(a.at("chain_seeds")[0].get<unsigned long>(), 4u);
  ASSERT_EQ(a.at("per_chain").size(), 3u);
  for (const char* k : {"axial_um", "transverse_um", "energy_pNum", "area_um2", "volume_um3"}) {
    EXPECT_TRUE(a.at(k).contains("rhat")) << k;
    EXPECT_TRUE(a.at(k).contains("between_chain_error")) << k;
  }
  EXPECT_TRUE(a.contains("converged"));
  EXPECT_TRUE(a.contains("thermal_shift_axial_error_um"));
  // The pooled mean is the mean of the chain means.
  double mean = 0;
  for (const json& c : a.at("per_chain")) mean += c.at("axial_um").at("mean").get<double>() / 3;
  EXPECT_NEAR(a.at("axial_um").at("mean").get<double>(), mean, 1e-12 * mean);
  // A series file per chain, identical on both thread counts; chains differ from each other.
  for (const char* f : {"mc_series.csv", "mc_series_chain1.csv", "mc_series_chain2.csv"}) {
    const std::string sa = data_lines(dir / "one" / f), sb = data_lines(dir / "two" / f);
    EXPECT_FALSE(sa.empty()) << f;
    EXPECT_TRUE(sa == sb) << f << " differs between 1 and 2 threads";
  }
  EXPECT_NE(data_lines(dir / "one" / "mc_series.csv"),
            data_lines(dir / "one" / "mc_series_chain1.csv"));
  const json summary = json::parse(std::ifstream(dir / "one" / "mc_summary.json"));
  EXPECT_EQ(summary.at("axial_um"), a.at("axial_um"));
}

TEST(McChainsCli, CheckpointOfEveryChainResumesBitForBitOnAnotherThreadCount) {
  const fs::path dir = fresh_output_dir("mc_chains_cli_resume");
  const std::string base = "mc -n 150 --force 20 --seed 9 --adapt-sweeps 8 -q --json ";
  const CliRun straight = run_rbc(base + "--sweeps 40", 1);
  ASSERT_EQ(straight.exit_code, 0) << straight.all();
  const std::string cp = shell_quoted(dir / "chains.h5");
  const CliRun first = run_rbc(base + "--sweeps 20 --checkpoint " + cp, 2);
  ASSERT_EQ(first.exit_code, 0) << first.all();
  const CliRun resumed = run_rbc(base + "--sweeps 40 --resume " + cp, 1);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.all();
  EXPECT_EQ(chain_fields(straight.out), chain_fields(resumed.out));
  // Another chain count is refused with exit 2, naming the checkpoint's.
  const CliRun other = run_rbc(base + "--sweeps 40 --chains 3 --resume " + cp, 1);
  EXPECT_EQ(other.exit_code, 2) << other.all();
  EXPECT_NE(other.err.find("holds 2 chains, not --chains 3"), std::string::npos) << other.err;
}

TEST(McChainsCli, CheckpointOfTheOneChainFormatIsRefusedWithExit2) {
  const fs::path dir = fresh_output_dir("mc_chains_cli_format");
  const std::string old = (dir / "format6.h5").string();
  {
    H5File h = H5File::create(old);
    h.write_attribute("format", 6LL);
    h.write_attribute("vertices", 150LL);
    h.write_attribute("bending_model", std::string("juelicher"));
  }
  const CliRun r = run_rbc("mc --sweeps 20 -q --resume " + shell_quoted(old));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_EQ(r.err.rfind("rbc: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("format version 6"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("reads version 7"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(McChainsCli, ForceListIsValidatedBeforeAnyWork) {
  for (const char* bad : {"--forces 0,1e9", "--forces 0,20 --force 5",
                          "--forces 0,20 --resume x.h5", "--forces 0,20 --checkpoint c.h5"}) {
    const CliRun r = run_rbc(std::string("mc -n 150 --sweeps 10 -q ") + bad);
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.all();
    EXPECT_EQ(r.err.rfind("rbc: error: --", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

// The force list over MPI ranks: 1 and 2 ranks give the same thermal curve, digit for digit,
// and the same per-force series of both chains; the curve's shift is D(T) - D(0 K).
TEST(McChainsCli, ForceListGivesTheSameCurveOnOneAndTwoMpiRanks) {
  const std::string mpirun = RBC_MPIRUN;
  if (mpirun.empty()) GTEST_SKIP() << "mpirun not found";
  const fs::path dir = fresh_output_dir("mc_chains_cli_mpi");
  const std::string args = std::string(RBC_BINARY_DIR) +
                           "/rbc mc -n 150 --forces 0,20,40 --sweeps 30 --seed 3 -q --no-picture "
                           "--json --out ";
  const CliRun one = run_rbc_shell(args + shell_quoted(dir / "one"));
  const CliRun two = run_rbc_shell(mpirun + " --allow-run-as-root --oversubscribe -np 2 " + args +
                                   shell_quoted(dir / "two"));
  ASSERT_EQ(one.exit_code, 0) << one.all();
  ASSERT_EQ(two.exit_code, 0) << two.all();
  const json a = json::parse(one.out), b = json::parse(two.out);
  EXPECT_EQ(a.at("mpi_ranks").get<int>(), 1);
  EXPECT_EQ(b.at("mpi_ranks").get<int>(), 2);
  EXPECT_EQ(a.at("curve"), b.at("curve"));
  ASSERT_EQ(a.at("curve").size(), 3u);
  for (const json& row : a.at("curve"))
    EXPECT_EQ(row.at("thermal_shift_axial_um").get<double>(),
              row.at("axial_um").get<double>() - row.at("reference_axial_um").get<double>());
  EXPECT_EQ(data_lines(dir / "one" / "thermal_curve.csv"),
            data_lines(dir / "two" / "thermal_curve.csv"));
  for (const char* f : {"force_01/mc_series.csv", "force_02/mc_series_chain1.csv"})
    EXPECT_EQ(data_lines(dir / "one" / f), data_lines(dir / "two" / f)) << f;
  // Forces differ in their seeds: force 0 and force 1 chains are different chains.
  const json s0 = json::parse(std::ifstream(dir / "one" / "force_00" / "mc_summary.json")),
             s1 = json::parse(std::ifstream(dir / "one" / "force_01" / "mc_summary.json"));
  EXPECT_EQ(s0.at("chain_seeds")[0].get<unsigned long>(), 3u);
  EXPECT_NE(s1.at("chain_seeds")[0], s0.at("chain_seeds")[0]);
  EXPECT_NE(s1.at("chain_seeds")[0], s0.at("chain_seeds")[1]);
}

}  // namespace
}  // namespace rbc
