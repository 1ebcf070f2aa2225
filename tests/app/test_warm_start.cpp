// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc stretch --warm-start DIR`: a re-solve after a small parameter change from the
// equilibria of an earlier `--out` reaches the same equilibrium as the cold continuation, in
// fewer Newton iterations, and is refused (exit 2, naming what differs) unless the model, the
// mesh and the forces match.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace {
namespace fs = std::filesystem;

struct CommandRun {
  int exit_code;
  std::string out;  // stdout
  std::string all;  // stdout and stderr
};

CommandRun rbc(const std::string& args) {
  // One stderr file per test case: ctest runs the cases of this file as parallel processes,
  // and a shared file let one case read the other's messages.
  const std::string err = std::string(RBC_BINARY_DIR) + "/test_output/warm_stderr_" +
                          ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".txt";
  // Two OpenMP threads in every run: warm and cold runs are compared across processes.
  const std::string cmd =
      "OMP_NUM_THREADS=2 " + std::string(RBC_BINARY_DIR) + "/rbc " + args + " 2>" + err;
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 512> buf{};
  while (fgets(buf.data(), buf.size(), p)) out += buf.data();
  const int status = pclose(p);
  std::ifstream e(err);
  const std::string errs((std::istreambuf_iterator<char>(e)), std::istreambuf_iterator<char>());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, out + errs};
}

std::string fresh_dir(const std::string& name) {
  const std::string dir = std::string(RBC_BINARY_DIR) + "/test_output/warm_" + name;
  fs::remove_all(dir);
  fs::create_directories(fs::path(dir).parent_path());
  return dir;
}

int total_iterations(const nlohmann::json& rows) {
  int n = 0;
  for (const auto& r : rows) n += r["iterations"].get<int>();
  return n;
}

const std::string kContinuum = "stretch --model continuum --elements 300 --force 0,30,88 -q --json";

TEST(WarmStart, ContinuumReSolveMatchesTheColdRunInFewerIterations) {
  const std::string dir = fresh_dir("continuum");
  ASSERT_EQ(rbc(kContinuum + " --out " + dir).exit_code, 0);
  // 1 % softer persistence length: cold continuation from rest vs warm from the stored run.
  const CommandRun cold = rbc(kContinuum + " --persistence 7.575");
  const CommandRun warm = rbc(kContinuum + " --persistence 7.575 --warm-start " + dir);
  ASSERT_EQ(cold.exit_code, 0) << cold.all;
  ASSERT_EQ(warm.exit_code, 0) << warm.all;
  const auto c = nlohmann::json::parse(cold.out).at("points"),
             w = nlohmann::json::parse(warm.out).at("points");
  ASSERT_EQ(c.size(), 3u);
  ASSERT_EQ(w.size(), 3u);
  for (size_t k = 0; k < c.size(); ++k) {
    EXPECT_TRUE(w[k]["warm_started"].get<bool>()) << k;
    EXPECT_TRUE(w[k]["converged"].get<bool>()) << k;
    // Both end at the same equilibrium to Newton's tolerance (1e-6 pN net vertex force).
    for (const char* d : {"axial_um", "transverse_um"})
      EXPECT_NEAR(w[k][d].get<double>(), c[k][d].get<double>(), 1e-7 * c[k][d].get<double>())
          << d << " at " << c[k]["force_pN"];
  }
  EXPECT_LT(total_iterations(w), total_iterations(c));
}

TEST(WarmStart, DiscreteReSolveReachesTheColdEquilibrium) {
  const std::string base = "stretch --model discrete -n 200 --force 0,30 -q --json";
  const std::string dir = fresh_dir("discrete");
  ASSERT_EQ(rbc(base + " --out " + dir).exit_code, 0);
  const CommandRun cold = rbc(base + " --lmax 240");
  const CommandRun warm = rbc(base + " --lmax 240 --warm-start " + dir);
  ASSERT_EQ(cold.exit_code, 0) << cold.all;
  ASSERT_EQ(warm.exit_code, 0) << warm.all;
  const auto c = nlohmann::json::parse(cold.out).at("points"),
             w = nlohmann::json::parse(warm.out).at("points");
  ASSERT_EQ(w.size(), 2u);
  for (size_t k = 0; k < c.size(); ++k) {
    EXPECT_TRUE(w[k]["warm_started"].get<bool>());
    // L-BFGS stops at 1e-3 pN per vertex: the two paths agree to ~1e-4 relative.
    for (const char* d : {"axial_um", "transverse_um"})
      EXPECT_NEAR(w[k][d].get<double>(), c[k][d].get<double>(), 1e-3 * c[k][d].get<double>()) << d;
  }
}

TEST(WarmStart, RefusedUnlessModelMeshAndForcesMatch) {
  const std::string dir = fresh_dir("refuse");
  ASSERT_EQ(rbc("stretch --model continuum --elements 300 --force 0,30 -q --out " + dir).exit_code,
            0);
  const std::string broken = fresh_dir("broken");
  fs::create_directories(broken);
  std::ofstream(broken + "/run.json") << "{ \"model\": \"continuum\", ";
  struct Case {
    std::string args, expect;
  };
  const Case cases[] = {
      {"--model continuum --elements 1000 --force 0,30 --warm-start " + dir, "same mesh"},
      {"--model continuum --elements 300 --force 0,40 --warm-start " + dir, "40"},
      // The same faces, laid another way on the cell.
      {"--model continuum --elements 300 --force 0,30 --mesh-orientation mirror-planes "
       "--warm-start " +
           dir,
       "--mesh-orientation dimple-vertex"},
      {"--model discrete -n 200 --force 0,30 --warm-start " + dir, "same model"},
      {"--model continuum --elements 300 --force 0 --warm-start /nonexistent/rbc_run", "run.json"},
      {"--model continuum --elements 300 --force 0 --warm-start " + broken, "not valid JSON"},
  };
  for (const auto& c : cases) {
    const CommandRun r = rbc("stretch -q " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.all;
    EXPECT_NE(r.all.find(c.expect), std::string::npos) << c.args << "\n" << r.all;
    EXPECT_NE(r.all.find("--warm-start"), std::string::npos) << r.all;
  }
  // A refusal found only once the mesh is built (the mesh differs) leaves no --out behind,
  // neither a fresh directory nor a manifest in an existing empty one.
  const std::string out_new = fresh_dir("refused_out_new");
  const std::string out_old = fresh_dir("refused_out_old");
  fs::create_directories(out_old);
  for (const std::string& out : {out_new, out_old}) {
    const CommandRun r =
        rbc("stretch -q --model continuum --elements 1000 --force 0,30 "
            "--warm-start " +
            dir + " --out " + out);
    EXPECT_EQ(r.exit_code, 2) << r.all;
    EXPECT_NE(r.all.find("same mesh"), std::string::npos) << r.all;
  }
  EXPECT_FALSE(fs::exists(out_new)) << "a refused run created " << out_new;
  ASSERT_TRUE(fs::is_directory(out_old));
  EXPECT_TRUE(fs::is_empty(out_old)) << "a refused run wrote into " << out_old;
}

TEST(WarmStart, ARunWithoutAnOrientationIsOnTheDefaultMesh) {
  // Runs that predate --mesh-orientation have no "mesh_orientation" in run.json: they were made
  // on the dimple-vertex mesh, and only a run on it may warm-start from them.
  const std::string dir = fresh_dir("no_orientation");
  ASSERT_EQ(rbc("stretch --model continuum --elements 300 --force 0 -q --out " + dir).exit_code, 0);
  nlohmann::json run;
  {
    std::ifstream in(dir + "/run.json");
    in >> run;
  }
  ASSERT_EQ(run.at("mesh_orientation"), "dimple-vertex");
  run.erase("mesh_orientation");
  std::ofstream(dir + "/run.json") << run.dump(2);
  const CommandRun ok =
      rbc("stretch -q --model continuum --elements 300 --force 0 --json --warm-start " + dir);
  EXPECT_EQ(ok.exit_code, 0) << ok.all;
  const CommandRun refused =
      rbc("stretch -q --model continuum --elements 300 --force 0 --mesh-orientation mirror-planes "
          "--warm-start " +
          dir);
  EXPECT_EQ(refused.exit_code, 2) << refused.all;
  EXPECT_NE(refused.all.find("--mesh-orientation dimple-vertex"), std::string::npos) << refused.all;
}

}  // namespace
