// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc dynamics`: bad input is refused with exit 2 before any work and nothing is
// written; a step that does not converge is halved (bounded), said on stderr, and a trajectory
// that still fails exits 1 with the residual in scientific notation; and the whole-cell
// release acceptance: the discrete and continuum recovery curves agree within 10 %, each
// fitted t_c is set by eta_m/mu (geometry factor), and t_c is proportional to eta_m.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {
namespace fs = std::filesystem;

/// Exit code, stdout and stderr of one `rbc dynamics` run.
struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

/// Runs `rbc dynamics ARGS` with one OpenMP thread, stdout and stderr to files under
/// test_output/cli_dynamics/TAG.{out,err}, read back.
CommandResult dynamics(const std::string& args, const std::string& tag) {
  const fs::path dir = fs::path(RBC_BINARY_DIR) / "test_output" / "cli_dynamics";
  fs::create_directories(dir);
  const fs::path out = dir / (tag + ".out"), err = dir / (tag + ".err");
  const std::string cmd = "OMP_NUM_THREADS=1 " + std::string(RBC_BINARY_DIR) + "/rbc dynamics " +
                          args + " > " + out.string() + " 2> " + err.string();
  const int status = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::stringstream so, se;
  so << std::ifstream(out).rdbuf();
  se << std::ifstream(err).rdbuf();
  r.out = so.str();
  r.err = se.str();
  return r;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::path(RBC_BINARY_DIR) / "test_output" / "cli_dynamics" / name;
  fs::remove_all(d);
  return d;
}

TEST(CliDynamics, BadTimesAndViscositiesExitTwoAndWriteNothing) {
  struct Case {
    const char* args;
    const char* expect;
  };
  const Case cases[] = {
      {"--dt 0", "--dt"},
      {"--dt -1e-3", "-0.001"},
      {"--dt nan", "nan"},
      {"--duration 0", "--duration"},
      {"--duration -2", "-2"},
      {"--dt 1e-9 --duration -1e-7", "-1e-07"},
      {"--membrane-viscosity 0", "--membrane-viscosity"},
      {"--membrane-viscosity -0.5", "-0.5"},
      {"--membrane-viscosity inf", "inf"},
      {"--dt 0.2 --duration 0.1", "at most the duration 0.1 s"},
      {"--model discrete --scene relax", "--scene relax"},
      {"--model discrete --force 600", "600"},
      {"--model continuum --force 450", "450"},
      {"--scene release --force 0", "--force"},
      {"--step-iterations -1", "--step-iterations"},
      {"--scene nope", "nope"},
      {"--scheme rk4", "rk4"},
      {"--model continuum --scheme bdf2", "--scheme bdf2"},
  };
  int k = 0;
  for (const auto& c : cases) {
    const fs::path out = fresh_dir("bad" + std::to_string(k));
    const CommandResult r =
        dynamics(std::string(c.args) + " --out " + out.string(), "bad" + std::to_string(k));
    ++k;
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find("rbc: error:"), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out) && !fs::is_empty(out)) << c.args;
  }
}

// Three L-BFGS iterations cannot finish a 10 ms release step: the step is halved twice, each
// halving said on stderr, then the run stops with exit 1, the residual in scientific notation,
// and nothing written.
TEST(CliDynamics, StepThatDoesNotConvergeIsHalvedThenFailsWithExitOne) {
  const fs::path out = fresh_dir("halving");
  const CommandResult r = dynamics(
      "--model discrete -n 250 --force 50 --duration 0.02 --dt 0.01 --step-iterations 3 "
      "--max-halvings 2 --out " +
          out.string(),
      "halving");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("dt halved down to 0.0025 s"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("did not converge after 2 halvings"), std::string::npos) << r.err;
  // The residual is printed in scientific notation (never rounded to "0.0"), whatever its size:
  // read it back as a number.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.err, m, std::regex(R"(residual ([0-9]\.[0-9]+e[+-][0-9]+) pN)")))
      << r.err;
  const double residual_pN = std::stod(m[1].str());
  EXPECT_TRUE(std::isfinite(residual_pN) && residual_pN > 0) << r.err;
  EXPECT_FALSE(fs::exists(out) && !fs::is_empty(out));
}

struct Release {
  double tc = 0, tc_err = 0, geometry = 0, kelvin_voigt = 0, eta_hochmuth = 0;
  std::vector<double> t, r;  ///< time (s), (lambda - lambda_inf)/(lambda(0) - lambda_inf)
};

Release release(const std::string& args, const std::string& tag) {
  const CommandResult run = dynamics("--scene release --json -q " + args, tag);
  EXPECT_EQ(run.exit_code, 0) << args << "\n" << run.err;
  Release out;
  if (run.exit_code != 0) return out;
  const auto j = nlohmann::json::parse(run.out);
  EXPECT_TRUE(j.at("recovery_fit_valid").get<bool>()) << args;
  out.tc = j.at("recovery_time_s");
  out.tc_err = j.at("recovery_time_err_s");
  out.geometry = j.at("geometry_factor");
  out.kelvin_voigt = j.at("kelvin_voigt_time_s");
  out.eta_hochmuth = j.at("eta_matching_hochmuth_pN_s_per_um");
  const double linf = j.at("lambda_inf");
  const auto& s = j.at("samples");
  const double l0 = s[0].at("axial_um").get<double>() / s[0].at("transverse_um").get<double>();
  for (const auto& p : s) {
    out.t.push_back(p.at("t_s"));
    const double l = p.at("axial_um").get<double>() / p.at("transverse_um").get<double>();
    out.r.push_back((l - linf) / (l0 - linf));
  }
  return out;
}

// The whole-cell release acceptance at a small size (N ~ 250 vertices, 400 elements, 50 pN,
// dt = 5 ms, 0.3 s; a few seconds each): the two scales' normalised recovery curves differ by
// less than 0.1 of the initial amplitude at every sample, their fitted t_c by less than 10 %,
// and each t_c is eta_m/mu times a geometry factor within 25 % of 1 (measured: 1.04 discrete,
// 0.98 continuum). The JSON's Hochmuth viscosity is eta_m t_c(Hochmuth)/t_c.
TEST(CliDynamics, WholeCellReleaseAgreesAcrossScalesWithinTenPercent) {
  const std::string common = "--force 50 --duration 0.3 --dt 0.005 --membrane-viscosity 0.7";
  const Release d = release("--model discrete -n 250 " + common, "release_discrete");
  const Release c = release("--model continuum --elements 400 " + common, "release_continuum");
  ASSERT_EQ(d.t.size(), 61u);
  ASSERT_EQ(c.t.size(), d.t.size());
  double worst = 0;
  for (size_t k = 0; k < d.t.size(); ++k) {
    ASSERT_NEAR(d.t[k], c.t[k], 1e-12);
    worst = std::max(worst, std::abs(d.r[k] - c.r[k]));
  }
  EXPECT_LT(worst, 0.1);
  EXPECT_LT(std::abs(d.tc - c.tc) / (0.5 * (d.tc + c.tc)), 0.1) << d.tc << " " << c.tc;
  for (const Release* x : {&d, &c}) {
    EXPECT_NEAR(x->geometry, 1.0, 0.25);
    EXPECT_LT(x->tc_err, 0.02 * x->tc);
    EXPECT_NEAR(x->eta_hochmuth / 0.7, 0.1239 / x->tc, 0.01 * 0.1239 / x->tc);
  }
}

// Without fluids the only time scale is eta_m/mu: doubling eta_m and dt (same force tolerance
// in pN) gives the same sequence of step problems, so t_c doubles (to the solver's rounding).
// This is what the Hochmuth-matching viscosity eta_m t_c(Hochmuth)/t_c relies on.
TEST(CliDynamics, RecoveryTimeIsProportionalToTheMembraneViscosity) {
  const std::string common = "--model discrete -n 250 --force 50";
  const Release a =
      release(common + " --membrane-viscosity 0.7 --dt 0.005 --duration 0.3 --tolerance 1", "eta1");
  const Release b = release(
      common + " --membrane-viscosity 1.4 --dt 0.01 --duration 0.6 --tolerance 0.5", "eta2");
  ASSERT_GT(a.tc, 0);
  EXPECT_NEAR(b.tc / a.tc, 2.0, 1e-6);  // measured: 2 to 1e-15
  EXPECT_NEAR(b.kelvin_voigt / a.kelvin_voigt, 2.0, 1e-12);
}

}  // namespace

namespace {

nlohmann::json relax(const std::string& args, const std::string& tag) {
  const CommandResult r =
      dynamics("--model continuum --scene relax --elements 400 --json -q " + args, tag);
  EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
  return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
}

// The relax scene (qualitative) claims a Helfrich relaxation at fixed area and volume whose pace
// is set by the dissipation: the energy never increases, the trajectory ends at the static
// relaxation of `rbc relax` (relax_helfrich, same mesh and regulariser; measured: diameter to
// 2e-6, thicknesses to 3e-5 relative), and, as stated in its JSON, the membrane viscosity
// (through the tangential flow the shape change needs) sets the pace far more than the
// fluids' normal drag: over the first 0.1 s (one step), measured at 400 elements, 10 x eta_m
// moves the rim 7 x less, 10 x the normal drag only 1.2 x less.
TEST(CliDynamics, RelaxSceneEndsAtTheStaticHelfrichRelaxation) {
  const nlohmann::json j = relax("--duration 100 --dt 5", "relax");
  ASSERT_TRUE(j.contains("samples"));
  ASSERT_TRUE(j.at("static_relax_converged").get<bool>());
  const auto& s = j.at("samples");
  ASSERT_EQ(s.size(), 21u);
  for (size_t k = 1; k < s.size(); ++k)
    EXPECT_LE(s[k].at("energy_pNum").get<double>(), s[k - 1].at("energy_pNum").get<double>() + 1e-9)
        << k;
  const double d0 = j.at("disc_diameter_before_um"), d = j.at("disc_diameter_after_um");
  const double ds = j.at("static_disc_diameter_um");
  EXPECT_GT(std::abs(ds - d0), 0.1);  // the relaxation is not trivial
  EXPECT_NEAR(d / ds, 1.0, 1e-4);
  EXPECT_NEAR(j.at("thickness_centre_after_um").get<double>() /
                  j.at("static_thickness_centre_um").get<double>(),
              1.0, 1e-3);
  EXPECT_NEAR(
      j.at("thickness_rim_after_um").get<double>() / j.at("static_thickness_rim_um").get<double>(),
      1.0, 1e-3);
  EXPECT_NE(j.at("fluids").at("note").get<std::string>().find("qualitative"), std::string::npos);
  const auto first_step = [](const std::string& args, const std::string& tag) {
    const nlohmann::json r = relax("--duration 0.1 --dt 0.1 " + args, tag);
    if (!r.contains("samples")) return 0.0;
    const auto& v = r.at("samples");
    return v[1].at("axial_um").get<double>() - v[0].at("axial_um").get<double>();
  };
  const double base = first_step("", "relax_base");
  const double viscous = first_step("--membrane-viscosity 7", "relax_eta");
  const double dragged = first_step("--normal-drag 0.035", "relax_drag");
  EXPECT_GT(base, 0.02);
  EXPECT_LT(viscous, base / 3);
  EXPECT_GT(dragged, base / 2);
  EXPECT_LT(dragged, base);
}

}  // namespace

namespace {

/// The data rows of a CSV file (its "#" comment lines, which carry the date and the command
/// line, left out).
std::vector<std::string> csv_rows(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> rows;
  for (std::string line; std::getline(in, line);)
    if (line.rfind('#', 0) != 0) rows.push_back(line);
  return rows;
}

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// The model option group reaches the scene. The WLC link energy is k_B T Lmax/(4 p) times a
// function of L/Lmax: its stiffness scales as k_B T/p, so a LARGER persistence length p is a
// SOFTER network. With --persistence 10 (default 7.5 nm) the shear modulus is 7.5/10 of the
// default's, the Kelvin-Voigt time eta_m/mu 10/7.5 of it, and the same force stretches the cell
// further: the static D_A under load and the D_A the trajectory reaches are both larger.
TEST(CliDynamics, LargerPersistenceLengthGivesASofterNetwork) {
  const std::string args =
      "--model discrete -n 250 --scene stretch --force 50 --duration 0.1 --dt 0.01 --json -q";
  const CommandResult a = dynamics(args, "persistence_default");
  const CommandResult b = dynamics(args + " --persistence 10", "persistence_10");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto ja = nlohmann::json::parse(a.out), jb = nlohmann::json::parse(b.out);
  EXPECT_EQ(ja.at("config").at("persistence").get<double>(), 7.5);
  EXPECT_EQ(jb.at("config").at("persistence").get<double>(), 10.0);
  EXPECT_EQ(jb.at("command"), "dynamics");
  EXPECT_TRUE(jb.at("provenance").contains("rbc_version"));
  EXPECT_NEAR(jb.at("shear_modulus_pN_per_um").get<double>() /
                  ja.at("shear_modulus_pN_per_um").get<double>(),
              0.75, 1e-12);
  EXPECT_NEAR(
      jb.at("kelvin_voigt_time_s").get<double>() / ja.at("kelvin_voigt_time_s").get<double>(),
      10.0 / 7.5, 1e-12);
  const double static_a = ja.at("static_axial_um"), static_b = jb.at("static_axial_um");
  const double end_a = ja.at("samples").back().at("axial_um");
  const double end_b = jb.at("samples").back().at("axial_um");
  const double rest_a = ja.at("samples").front().at("axial_um");
  EXPECT_GT(static_b - rest_a, 1.1 * (static_a - rest_a)) << static_a << " " << static_b;
  EXPECT_GT(end_b, end_a + 0.1) << end_a << " " << end_b;
}

// A run's run.json repeats it: `--config D/run.json --out E` reads the options back (here a
// non-default persistence length and scene) and gives the same numbers, bit for bit.
TEST(CliDynamics, ConfigFromRunJsonRepeatsTheRunBitForBit) {
  const fs::path d = fresh_dir("config_first"), e = fresh_dir("config_again");
  const CommandResult first = dynamics(
      "--model discrete -n 250 --scene release --force 40 --persistence 10 --kappa 3e-19 "
      "--duration 0.05 --dt 0.005 --no-picture -q --out " +
          d.string(),
      "config_first");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const nlohmann::json run = read_json(d / "run.json");
  EXPECT_TRUE(run.at("complete").get<bool>());
  EXPECT_EQ(run.at("config").at("persistence").get<double>(), 10.0);
  const CommandResult again =
      dynamics("--config " + (d / "run.json").string() + " --out " + e.string(), "config_again");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const std::vector<std::string> rows = csv_rows(d / "dynamics.csv");
  ASSERT_EQ(rows.size(), 12u);  // header and 11 samples
  EXPECT_EQ(csv_rows(e / "dynamics.csv"), rows);
  nlohmann::json a = read_json(d / "dynamics.json"), b = read_json(e / "dynamics.json");
  for (nlohmann::json* j : {&a, &b}) {
    j->erase("wall_s");
    j->erase("provenance");
    j->at("config").erase("out");
  }
  EXPECT_EQ(a, b);
  EXPECT_EQ(b.at("force_pN").get<double>(), 40.0);
  EXPECT_EQ(b.at("config").at("kappa").get<double>(), 3e-19);
  // The record is in the CSV comments too.
  std::ifstream csv(e / "dynamics.csv");
  std::stringstream text;
  text << csv.rdbuf();
  EXPECT_NE(text.str().find("\"persistence\":10"), std::string::npos) << text.str();
}

}  // namespace
