// SPDX-License-Identifier: GPL-3.0-or-later
// The command-line contract: bad input gives exit code 2 and one clear line, never a
// crash or a partial file; good input gives the documented fields.
#include <gtest/gtest.h>

#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "cli_run.hpp"
#include "core/h5file.hpp"

namespace {
namespace fs = std::filesystem;

struct CommandRun {
  int exit_code;
  std::string output;  // stderr then stdout: messages and failure reports
  std::string out;     // stdout alone: the JSON
};

CommandRun rbc(const std::string& args) {
  const rbc::testing::CliRun r = rbc::testing::run_rbc(args, /*threads=*/0);
  return {r.exit_code, r.all(), r.out};
}

std::string fresh_dir(const std::string& name) {
  const std::string dir = std::string(RBC_BINARY_DIR) + "/test_output/cli_" + name;
  fs::remove_all(dir);
  return dir;
}

TEST(Cli, BadInputExitsTwoWithAClearMessage) {
  struct Case {
    std::string args;
    const char* expect;  // a fragment the message must contain
  };
  const Case cases[] = {
      {"stretch --no-such-option", "no-such-option"},
      {"stretch --force 0,abc -n 200", "abc"},
      {"stretch --force -5 -n 200", "-5"},
      {"stretch --force 10 -n 50", "50"},
      {"stretch --force 10 -n 200 --lmax 60", "Lmax"},
      {"stretch --force 10 -n 200 --eta -1", "eta"},
      {"stretch --force 10 -n 200 --bending nope", "nope"},
      {"stretch --force 10 --model nope", "nope"},
      {"stretch --force 10 --model continuum --symmetry mirror --symmetry-check top", "top"},
      {"stretch --force 10 -n 200 --symmetry mirror --symmetry-check highest-force",
       "--symmetry-check"},
      {"stretch --force 10 --model continuum --symmetry-check highest-force", "--symmetry none"},
      {"fig7 --force 10,5 --method discrete:150 --out " + fresh_dir("never_written"), "increase"},
      {"fig7 --method bogus:1", "bogus"},
      {"stretch --force 10 -n 200 --out /proc/rbc_cannot_write_here", "rbc_cannot_write_here"},
      {"mc -n 150 --temperature -5", "-5"},
      {"mc -n 150 --sweeps -3", "sweeps"},
      {"mc -n 150 --penalty-scale 0", "penalty"},
      {"mc -n 150 --bending nope", "nope"},
      {"mc -n 150 --resume /nonexistent/rbc_chain.h5", "rbc_chain.h5"},
      {"bench nope", "nope"},
  };
  for (const auto& c : cases) {
    const CommandRun r = rbc(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find("error"), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << "\n" << r.output;
  }
}

// A run that fails after it has written some outputs (here the second shape cannot be moved into
// place: a directory stands at its name) exits 2 and leaves no temporary file; every file it
// leaves is complete and named by run.json, which says the run failed and why.
TEST(Cli, FailedRunLeavesNoPartialFiles) {
  const std::string dir = fresh_dir("partial");
  fs::create_directories(dir + "/shape_16.0pN.h5");  // the obstacle
  const CommandRun r = rbc("stretch --force 0,16,38 -n 200 -q --force-overwrite --out " + dir);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("shape_16.0pN.h5"), std::string::npos) << r.output;
  std::ifstream in(dir + "/run.json");
  ASSERT_TRUE(in) << "no run.json";
  const auto j = nlohmann::json::parse(in);
  EXPECT_FALSE(j.at("complete").get<bool>());
  EXPECT_EQ(j.at("status").get<std::string>(), "failed");
  EXPECT_NE(j.at("reason").get<std::string>().find("shape_16.0pN.h5"), std::string::npos);
  std::set<std::string> named = {"run.json", "shape_16.0pN.h5"};
  ASSERT_EQ(j.at("forces_complete").size(), 1u);  // 0 pN was written before the failure
  for (const auto& f : j.at("forces_complete")) {
    named.insert(f.at("shape_h5").get<std::string>());
    named.insert(f.at("shape_xdmf").get<std::string>());
  }
  std::set<std::string> present;
  for (const auto& e : fs::directory_iterator(dir)) present.insert(e.path().filename().string());
  EXPECT_EQ(present, named);  // nothing else: no temporary, no half-written table
  // The shape that was written is complete: it reads back with every vertex.
  std::vector<double> x;
  const auto shape = rbc::H5File::open_read(dir + "/shape_0.0pN.h5").read("/mesh/positions_um", x);
  EXPECT_EQ(shape.second, 3u);
  EXPECT_EQ(x.size(), 3 * shape.first);
  EXPECT_GT(shape.first, 100u);
}

TEST(Cli, NonEmptyOutputDirectoryIsRefusedWithoutOverwrite) {
  const std::string dir = fresh_dir("nonempty");
  fs::create_directories(dir);
  std::FILE* f = std::fopen((dir + "/keep.txt").c_str(), "w");
  std::fclose(f);
  const CommandRun r = rbc("fig7 --method discrete:150 --force 0,50 --out " + dir);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("not empty"), std::string::npos);
}

TEST(Cli, StretchJsonHasTheDocumentedFieldsAndWritesFilesThatOpen) {
  const std::string dir = fresh_dir("stretch");
  const CommandRun r =
      rbc("stretch --model discrete --force 0,50 -n 200 --json --quiet --out " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.out).at("points");
  ASSERT_EQ(j.size(), 2u);
  for (const char* key : {"force_pN", "axial_um", "transverse_um", "energy_pNum", "iterations",
                          "converged", "wall_s", "vertices"})
    EXPECT_TRUE(j[0].contains(key)) << key;
  EXPECT_GT(j[1]["axial_um"].get<double>(), j[0]["axial_um"].get<double>());
  for (const char* f : {"stretch.csv", "run.json", "shape_0.0pN.h5", "shape_0.0pN.xdmf",
                        "shape_50.0pN.h5", "shape_50.0pN.xdmf"})
    EXPECT_TRUE(fs::exists(dir + "/" + f)) << f;
}

// run.json records what ran the job: the OpenMP threads and the BLAS, whose kernel (here chosen
// through OPENBLAS_CORETYPE, as the machines of this project do) sets the factorisation's speed
// and last bits.
TEST(Cli, StretchManifestRecordsTheThreadsAndTheBlasKernel) {
#if !defined(__x86_64__)
  GTEST_SKIP() << "OpenBLAS's kernel names here are x86-64's";
#endif
  // Kernels every x86-64 CPU of the last fifteen years runs (SSE3, SSE4.2).
  for (const std::string kernel : {"Prescott", "Nehalem"}) {
    const std::string dir = fresh_dir("manifest_blas_" + kernel);
    const std::string cmd =
        "env OPENBLAS_CORETYPE=" + kernel + " OMP_NUM_THREADS=1 " + std::string(RBC_BINARY_DIR) +
        "/rbc stretch --model discrete --force 0 -n 200 --quiet --out " + dir + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::array<char, 512> buf{};
    std::string out;
    while (fgets(buf.data(), buf.size(), p)) out += buf.data();
    const int status = pclose(p);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;
    std::ifstream in(dir + "/run.json");
    const auto j = nlohmann::json::parse(in);
    EXPECT_EQ(j.at("provenance").at("openmp_threads").get<int>(), 1);
    const auto& blas = j.at("provenance").at("blas");
    if (blas.at("library") != "OpenBLAS") GTEST_SKIP() << "not OpenBLAS: " << blas.dump();
    if (blas.at("config").get<std::string>().find("DYNAMIC_ARCH") == std::string::npos)
      GTEST_SKIP() << "OpenBLAS without DYNAMIC_ARCH ignores OPENBLAS_CORETYPE";
    std::string core = blas.at("core").get<std::string>();
    std::string want = kernel;
    for (auto* t : {&core, &want})
      for (char& c : *t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    EXPECT_EQ(core, want) << blas.dump();
    EXPECT_NE(blas.at("config").get<std::string>().find("OpenBLAS"), std::string::npos);
  }
}

// rbc bench names the BLAS kernel and whether the CPU has AVX-512 in its context block (the
// kernel moves the factorisation rows by 14-25 %), the latter as this process's CPUID says.
TEST(Cli, BenchContextNamesTheBlasKernelAndTheCpusAvx512) {
  const CommandRun r = rbc(
      "bench stretch --benchmark_filter=discrete/energy_gradient/500 --benchmark_min_time=0.01");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("blas: "), std::string::npos) << r.output;
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  const bool has_avx512f = __builtin_cpu_supports("avx512f");
#else
  const bool has_avx512f = false;
#endif
  const std::string avx512 = std::string("cpu_avx512f: ") + (has_avx512f ? "yes" : "no");
  EXPECT_NE(r.output.find(avx512), std::string::npos) << r.output;
}

// A resumed Monte Carlo run rebuilds the checkpoint's network (size and bending model) without
// being told, continues the chain to the requested total, and refuses a contradicting option.
TEST(Cli, McResumeRebuildsTheCheckpointsNetwork) {
  const std::string dir = fresh_dir("mc_resume");
  fs::create_directories(dir);
  const std::string cp = dir + "/chain.h5";
  const CommandRun first =
      rbc("mc -n 150 --bending dihedral --force 20 --sweeps 20 --json -q --checkpoint " + cp);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const auto j1 = nlohmann::json::parse(first.out);
  const CommandRun resumed = rbc("mc --sweeps 40 --json -q --resume " + cp);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  const auto j2 = nlohmann::json::parse(resumed.out);
  EXPECT_EQ(j2["vertices"], j1["vertices"]);
  EXPECT_EQ(j2["bending"], "dihedral");
  EXPECT_EQ(j2["sweeps"], 40);
  EXPECT_EQ(j2["sweeps_this_run"], 20);
  EXPECT_EQ(j2["force_pN"], j1["force_pN"]);
  const CommandRun wrong = rbc("mc --sweeps 40 -q --bending juelicher --resume " + cp);
  EXPECT_EQ(wrong.exit_code, 2) << wrong.output;
  EXPECT_NE(wrong.output.find("dihedral"), std::string::npos) << wrong.output;
}

}  // namespace
