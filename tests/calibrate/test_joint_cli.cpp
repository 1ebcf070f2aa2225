// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer` with several --data-file options: one posterior over both files, each file in the
// summary with its content hash and its own fit plot; a --resume with another file list, or
// with a file changed, is refused with exit 2; a bad per-file option exits 2 with one line
// before any work.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "app/cli_run.hpp"
#include "test_output.hpp"

namespace {
namespace fs = std::filesystem;
using rbc::testing::run_rbc;

std::string read(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Tables {
  fs::path a, b;
};
Tables tables(const fs::path& dir) {
  const Tables t{dir / "table_a.csv", dir / "table_b.csv"};
  std::ofstream(t.a) << "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                        "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n90,13.8,1.2,4.6,0.6\n";
  std::ofstream(t.b) << "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                        "0,7.7,0.6,7.7,0.6\n45,11.6,1.0,5.2,0.7\n90,14.1,1.1,4.4,0.5\n";
  return t;
}

const std::string kCommon = " -q --method continuum:2:200 --seed 3 --params persistence";

TEST(JointCli, TwoDataFilesMakeOnePosteriorWithEachFileRecorded) {
  const fs::path dir = rbc::testing::fresh_output_dir("joint_cli");
  const Tables t = tables(dir);
  const std::string files = " --data-file " + t.a.string() + " --data-file " + t.b.string();
  const auto r = run_rbc("infer --sampler laplace-is --is-samples 120" + kCommon + files +
                             " --extra-uncertainty table_b=0.2 --out " + (dir / "out").string(),
                         1);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const auto j = nlohmann::json::parse(read(dir / "out" / "summary.json"));
  ASSERT_EQ(j["data_sets"].size(), 2u);
  EXPECT_EQ(j["data_sets"][0]["stem"], "table_a");
  EXPECT_EQ(j["data_sets"][1]["stem"], "table_b");
  EXPECT_EQ(j["data_sets"][0]["added_extra_uncertainty_um"], 0.0);
  EXPECT_EQ(j["data_sets"][1]["added_extra_uncertainty_um"], 0.2);
  EXPECT_NE(j["data_sets"][0]["contents"], j["data_sets"][1]["contents"]);
  EXPECT_EQ(j["data_sets"][1]["points"].size(), 3u);
  for (const char* f : {"predictive_table_a.csv", "predictive_table_b.csv", "predictive.csv"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
}

TEST(JointCli, ResumeWithOtherFilesIsRefused) {
  const fs::path dir = rbc::testing::fresh_output_dir("joint_cli_resume");
  const Tables t = tables(dir);
  const std::string both = " --data-file " + t.a.string() + " --data-file " + t.b.string();
  const std::string out = (dir / "out").string();
  const auto r = run_rbc(
      "infer" + kCommon + both + " --sampler tmcmc --samples 20 --chain-length 1 --out " + out, 1);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  ASSERT_TRUE(fs::exists(dir / "out" / "checkpoint.h5"));
  const std::string summary = read(dir / "out" / "summary.json");
  // The same files resume (the run is complete: the straight run's result again).
  const auto same = run_rbc(
      "infer" + kCommon + both + " --sampler tmcmc --samples 20 --chain-length 1 --resume " + out,
      1);
  EXPECT_EQ(same.exit_code, 0) << same.all();
  // One file fewer, the order swapped, or a file changed: refused, naming the data files.
  const fs::path changed = dir / "changed" / "table_b.csv";
  fs::create_directories(changed.parent_path());
  std::ofstream(changed) << read(t.b) << "120,15.0,1.2,4.3,0.5\n";
  for (const std::string& files :
       {" --data-file " + t.a.string(),
        " --data-file " + t.b.string() + " --data-file " + t.a.string(),
        " --data-file " + t.a.string() + " --data-file " + changed.string()}) {
    const auto bad = run_rbc("infer" + kCommon + files +
                                 " --sampler tmcmc --samples 20 --chain-length 1 --resume " + out,
                             1);
    EXPECT_EQ(bad.exit_code, 2) << files << "\n" << bad.all();
    EXPECT_NE(bad.err.find("--data-file"), std::string::npos) << bad.err;
  }
}

TEST(JointCli, BadPerFileOptionsExitTwoWithOneLine) {
  const fs::path dir = rbc::testing::fresh_output_dir("joint_cli_bad");
  const Tables t = tables(dir);
  const std::string both = " --data-file " + t.a.string() + " --data-file " + t.b.string();
  struct Case {
    std::string args, expect;
  };
  for (const Case& c : std::vector<Case>{
           {"--extra-uncertainty table_c=0.1", "rbc: error: --extra-uncertainty table_c"},
           {"--extra-uncertainty table_a=-0.1", "rbc: error: --extra-uncertainty table_a=-0.1"},
           {"--extra-uncertainty table_a=x", "rbc: error: --extra-uncertainty table_a=x"},
           {"--extra-uncertainty 0.1 --extra-uncertainty 0.2", "rbc: error: --extra-uncertainty"},
           {"--per-experiment contact-fraction", "rbc: error: --per-experiment contact-fraction"},
           {"--params persistence,sigma-scale --per-experiment sigma-scale",
            "rbc: error: --per-experiment sigma-scale"},
           {"--params persistence,eta-m", "rbc: error: --params eta-m"},
           {"--data-file " + t.a.string(), "rbc: error: --data-file"},  // the same stem twice
       }) {
    const fs::path out = dir / "out";
    const std::string params =
        c.args.find("--params") == std::string::npos ? " --params persistence " : " ";
    const auto r = run_rbc(
        "infer -q --method continuum:2:200" + params + c.args + both + " --out " + out.string(), 1);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.all();
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out / "summary.json")) << c.args;
  }
}

}  // namespace
