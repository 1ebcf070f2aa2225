// SPDX-License-Identifier: GPL-3.0-or-later
// What produced an output and how to repeat it: `--config FILE` on every sub-command, the
// resolved configuration written back into run.json (a run repeated from it is bit-identical),
// and the provenance (version, command line, date, threads, BLAS) in run.json, the CSV comment
// lines, the HDF5 attributes and --json.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "app/cli_run.hpp"
#include "core/h5file.hpp"
#include "test_output.hpp"

namespace {
namespace fs = std::filesystem;
using rbc::testing::run_rbc;

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

/// The positions of a written shape (um), as stored.
std::vector<double> shape_positions(const fs::path& h5) {
  std::vector<double> x;
  rbc::H5File::open_read(h5.string()).read("/mesh/positions_um", x);
  return x;
}

/// The physics of a point that two repeats of a run must share to the last bit (not wall_s).
nlohmann::json physics_of(const nlohmann::json& points) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& p : points)
    out.push_back({p.at("force_pN"), p.at("axial_um"), p.at("transverse_um"), p.at("energy_pNum"),
                   p.at("iterations"), p.at("residual_pN")});
  return out;
}

const std::string kSmallStretch = "stretch --force 0,50 --vertices 300 --quiet";

TEST(RunConfig, StretchRepeatsBitIdenticallyFromItsRunJson) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_repeat");
  const auto a = run_rbc(kSmallStretch + " --persistence 10 --lmax 200 --out " +
                         (d / "D").string() + " --no-picture");
  ASSERT_EQ(a.exit_code, 0) << a.all();
  const nlohmann::json run = read_json(d / "D" / "run.json");
  // The resolved configuration names every option, given or default.
  const nlohmann::json& config = run.at("config");
  EXPECT_EQ(config.at("persistence"), 10);
  EXPECT_EQ(config.at("lmax"), 200);
  EXPECT_EQ(config.at("lbar"), 75);           // a default
  EXPECT_EQ(config.at("model"), "discrete");  // a choice, by name
  EXPECT_EQ(config.at("force"), nlohmann::json::array({0, 50}));
  // `grep persistence D/run.json D/*.csv` finds the value.
  EXPECT_NE(read_text(d / "D" / "stretch.csv").find("\"persistence\":10"), std::string::npos);

  // Repeated from its run.json into another directory: the same equilibria, to the last bit.
  const auto b = run_rbc("stretch --config " + (d / "D" / "run.json").string() + " --out " +
                         (d / "E").string() + " --json");
  ASSERT_EQ(b.exit_code, 0) << b.all();
  const nlohmann::json repeat = nlohmann::json::parse(b.out);
  EXPECT_EQ(physics_of(repeat.at("points")), physics_of(run.at("points")));
  for (const char* shape : {"shape_0.0pN.h5", "shape_50.0pN.h5"})
    EXPECT_EQ(shape_positions(d / "E" / shape), shape_positions(d / "D" / shape)) << shape;
  // The repeat's configuration is the original's apart from where it wrote and what it printed.
  nlohmann::json c1 = config, c2 = repeat.at("config");
  for (auto* c : {&c1, &c2})
    for (const char* k : {"out", "json", "no-picture"}) c->erase(k);
  EXPECT_EQ(c1, c2);
}

TEST(RunConfig, CommandLineOverridesTheFile) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_override");
  write_text(d / "soft.json", R"({"persistence": 10, "force": [50], "vertices": 300})");
  const auto from_file = run_rbc("stretch --quiet --json --config " + (d / "soft.json").string());
  const auto overridden =
      run_rbc("stretch --quiet --json --persistence 7.5 --config " + (d / "soft.json").string());
  const auto plain = run_rbc("stretch --quiet --json --force 50 --vertices 300");
  ASSERT_EQ(from_file.exit_code, 0) << from_file.all();
  ASSERT_EQ(overridden.exit_code, 0) << overridden.all();
  ASSERT_EQ(plain.exit_code, 0) << plain.all();
  const auto axial = [](const std::string& out) {
    return nlohmann::json::parse(out).at("points").at(0).at("axial_um").get<double>();
  };
  // --persistence 7.5 on the command line wins over the file's 10: the default physics.
  EXPECT_EQ(axial(overridden.out), axial(plain.out));
  // The WLC links stiffen as k_B T / p falls: p = 10 nm is the softer network, so the cell
  // stretches further under the same 50 pN.
  EXPECT_GT(axial(from_file.out), axial(plain.out) + 0.05);
}

TEST(RunConfig, BadFilesAreRefusedNamingFileAndKey) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_bad");
  struct Case {
    std::string file, text, expected;
  };
  const std::vector<Case> cases = {
      {"typo.json", R"({"persistense": 10})", "'persistense' is not an option of rbc stretch"},
      {"broken.json", R"({"persistence": 10)", "not valid JSON"},
      {"list.json", R"([1, 2])", "expected a JSON object"},
      {"flag.json", R"({"json": 1})", "'json' is a flag: expected true or false"},
      {"object.json", R"({"lmax": {"nm": 200}})", "'lmax': expected a number"},
      {"value.json", R"({"lmax": -5})", "--lmax"},
      {"other.json", R"({"command": "mc", "config": {"sweeps": 10}})", "written by rbc \"mc\""},
  };
  for (const auto& c : cases) {
    write_text(d / c.file, c.text);
    const auto r = run_rbc(kSmallStretch + " --config " + (d / c.file).string());
    EXPECT_EQ(r.exit_code, 2) << c.file << ": " << r.all();
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.file << ": " << r.err;
    EXPECT_TRUE(r.out.empty()) << c.file << ": no work before the refusal";
  }
  const auto missing = run_rbc(kSmallStretch + " --config " + (d / "none.json").string());
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("none.json: cannot open: No such file or directory"),
            std::string::npos)
      << missing.err;
}

TEST(RunConfig, EveryCommandTakesAConfigFile) {
  for (const char* cmd : {"mesh", "stretch", "relax", "fig7", "tradeoff", "stability", "report",
                          "mc", "moduli", "psi", "dynamics", "infer", "render"}) {
    const auto r = run_rbc(std::string(cmd) + " --help");
    EXPECT_EQ(r.exit_code, 0) << cmd;
    EXPECT_NE(r.out.find("--config FILE"), std::string::npos) << cmd;
  }
}

TEST(RunConfig, EveryOutputOfStretchRecordsWhatProducedIt) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_provenance");
  const auto version = run_rbc("--version");
  ASSERT_EQ(version.exit_code, 0);
  std::string v = version.out;
  while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
  ASSERT_FALSE(v.empty());
  const auto r =
      run_rbc(kSmallStretch + " --lmax 210 --json --no-picture --out " + (d / "D").string(), 2);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const nlohmann::json run = read_json(d / "D" / "run.json");
  const nlohmann::json printed = nlohmann::json::parse(r.out);
  for (const nlohmann::json* j : {&run, &printed}) {
    const auto& p = j->at("provenance");
    EXPECT_EQ(j->at("command"), "stretch");
    EXPECT_NE(v.find(p.at("rbc_version").get<std::string>()), std::string::npos) << v;
    EXPECT_NE(p.at("command_line").get<std::string>().find("--lmax 210"), std::string::npos);
    EXPECT_EQ(p.at("openmp_threads"), 2);
    EXPECT_EQ(p.at("date_utc").get<std::string>().size(), 20u);  // 2026-12-06T09:19:20Z
    EXPECT_FALSE(p.at("blas").at("library").get<std::string>().empty());
    EXPECT_EQ(j->at("config").at("lmax"), 210);
  }
  const std::string csv = read_text(d / "D" / "stretch.csv");
  EXPECT_NE(csv.find("# rbc " + run.at("provenance").at("rbc_version").get<std::string>()),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find("\"lmax\":210"), std::string::npos);
  const rbc::H5File h5 = rbc::H5File::open_read((d / "D" / "shape_50.0pN.h5").string());
  EXPECT_EQ(h5.read_attribute_string("rbc_version"),
            run.at("provenance").at("rbc_version").get<std::string>());
  EXPECT_EQ(nlohmann::json::parse(h5.read_attribute_string("rbc_config")), run.at("config"));
  EXPECT_NE(h5.read_attribute_string("rbc_command_line").find("--lmax 210"), std::string::npos);
}

}  // namespace

namespace {

TEST(RunConfig, RelaxTakesTheModelGroupAndRepeatsFromItsRunJson) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_relax");
  const std::string base = "relax --elements 300 --h0 0 --quiet ";
  const auto stiff = run_rbc(base + "--kappa 4e-19 --out " + (d / "D").string());
  ASSERT_EQ(stiff.exit_code, 0) << stiff.all();
  const nlohmann::json run = read_json(d / "D" / "run.json");
  EXPECT_EQ(run.at("config").at("kappa"), 4e-19);
  const auto repeat = run_rbc("relax --json --config " + (d / "D" / "run.json").string() +
                              " --out " + (d / "E").string());
  const auto plain = run_rbc(base + "--json");
  ASSERT_EQ(repeat.exit_code, 0) << repeat.all();
  ASSERT_EQ(plain.exit_code, 0) << plain.all();
  const auto diameter = [](const std::string& out) {
    return nlohmann::json::parse(out).at("points").at(0).at("diameter_after_um").get<double>();
  };
  EXPECT_EQ(read_json(d / "E" / "relax.json").at(0).at("diameter_after_um"),
            read_json(d / "D" / "relax.json").at(0).at("diameter_after_um"));
  // A stiffer bilayer relaxes the Evans-Fung shape differently from the default one.
  EXPECT_NE(diameter(repeat.out), diameter(plain.out));
}

TEST(RunConfig, AccuracyTableRefusesPhysicsItWasNotMeasuredWith) {
  const auto r = run_rbc("tradeoff --accuracy-table --lmax 200 --out " +
                         rbc::testing::fresh_output_dir("run_config_table").string() + "/o");
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("--accuracy-table is measured at the default physics"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--lmax 200"), std::string::npos) << r.err;
}

}  // namespace

namespace {

// Progress per force at the default verbosity; the solver's internals only with --verbose.
TEST(RunConfig, SolverInternalsOnlyWithVerbose) {
  const auto plain = run_rbc("stretch --force 0,50 --vertices 300");
  const auto verbose = run_rbc("stretch --force 0,50 --vertices 300 --verbose");
  ASSERT_EQ(plain.exit_code, 0) << plain.all();
  ASSERT_EQ(verbose.exit_code, 0) << verbose.all();
  EXPECT_NE(plain.err.find("F = 50 pN"), std::string::npos) << plain.err;
  EXPECT_EQ(plain.err.find("preconditioner:"), std::string::npos) << plain.err;
  EXPECT_EQ(plain.err.find("s]   "), std::string::npos) << "an indented (internal) line\n"
                                                        << plain.err;
  EXPECT_NE(verbose.err.find("preconditioner:"), std::string::npos) << verbose.err;
}

}  // namespace

namespace {

// The picture of the cells carries the record as PNG text chunks (tEXt: key, NUL, text).
TEST(RunConfig, CellsPictureRecordsWhatProducedIt) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_png");
  const auto r = run_rbc(kSmallStretch + " --lmax 205 --out " + (d / "D").string());
  ASSERT_EQ(r.exit_code, 0) << r.all();
  if (!fs::exists(d / "D" / "cells.png")) GTEST_SKIP() << "no renderer here: " << r.err;
  const std::string png = read_text(d / "D" / "cells.png");
  const nlohmann::json run = read_json(d / "D" / "run.json");
  const std::string version = run.at("provenance").at("rbc_version").get<std::string>();
  EXPECT_NE(png.find(std::string("tEXtSoftware") + '\0' + "rbc " + version), std::string::npos);
  EXPECT_NE(png.find(std::string("tEXtrbc_config") + '\0' + run.at("config").dump()),
            std::string::npos);
  EXPECT_NE(png.find("--lmax 205"), std::string::npos);
}

}  // namespace

namespace {

/// D_A at the last force of `fig7 ... --out DIR`'s curve of one method (from its CSV).
double fig7_last_axial_um(const fs::path& csv) {
  std::ifstream in(csv);
  double axial = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("force_pN", 0) == 0) continue;
    std::stringstream row(line);
    std::string force, a;
    std::getline(row, force, ',');
    std::getline(row, a, ',');
    axial = std::stod(a);
  }
  return axial;
}

// fig7 runs both models with the Model options: a larger persistence length is a softer
// network (the WLC stiffness is k_B T / p), so both models stretch further at 193 pN.
TEST(RunConfig, Fig7TakesTheModelOptionsForBothModels) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_fig7");
  const std::string base =
      "fig7 --method discrete:150 --method continuum:2:200 --force 0,100,193 -q";
  const auto soft = run_rbc(base + " --persistence 10 --out " + (d / "soft").string());
  const auto plain = run_rbc(base + " --out " + (d / "plain").string());
  ASSERT_EQ(soft.exit_code, 0) << soft.all();
  ASSERT_EQ(plain.exit_code, 0) << plain.all();
  for (const char* csv : {"fig7_discrete_N150.csv", "fig7_continuum_p2_E200.csv"})
    EXPECT_GT(fig7_last_axial_um(d / "soft" / csv), fig7_last_axial_um(d / "plain" / csv) + 0.1)
        << csv;
  EXPECT_EQ(read_json(d / "soft" / "run.json").at("config").at("persistence"), 10);
  EXPECT_NE(read_text(d / "soft" / "fig7_fit.csv").find("\"persistence\":10"), std::string::npos);
}

}  // namespace

namespace {

// The Monte Carlo outputs record the run as stretch's do: CSV comment lines, HDF5 attributes.
TEST(RunConfig, MonteCarloOutputsRecordWhatProducedThem) {
  const fs::path d = rbc::testing::fresh_output_dir("run_config_mc");
  const auto r = run_rbc(
      "mc --vertices 150 --force 16 --sweeps 20 --seed 2 --lmax 220 -q "
      "--no-picture --out " +
      (d / "D").string());
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const nlohmann::json run = read_json(d / "D" / "run.json");
  const std::string version = run.at("provenance").at("rbc_version").get<std::string>();
  EXPECT_NE(read_text(d / "D" / "mc_series.csv").find("# rbc " + version), std::string::npos);
  const rbc::H5File h5 = rbc::H5File::open_read((d / "D" / "mc_series.h5").string());
  EXPECT_EQ(h5.read_attribute_string("rbc_version"), version);
  EXPECT_EQ(nlohmann::json::parse(h5.read_attribute_string("rbc_config")).at("lmax"), 220);
  bool snapshot = false;
  for (const auto& e : fs::directory_iterator(d / "D"))
    if (e.path().extension() == ".h5" &&
        e.path().filename().string().rfind("mc_snapshot", 0) == 0) {
      snapshot = true;
      EXPECT_EQ(rbc::H5File::open_read(e.path().string()).read_attribute_string("rbc_version"),
                version);
    }
  EXPECT_TRUE(snapshot);
}

}  // namespace
