// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc mc` from the command line: the thread decision recorded in --json and run.json (checked
// on its inputs, never by timing), --force spelled as every other command spells it, the
// snapshots' displacement fields (displacement_um the same quantity as in the stretch shapes,
// |x - X|; displacement_x_um its x component), the shared model options (a longer persistence
// length softens the links: the zero-temperature start agrees with `rbc stretch`), one
// --temperature for the links and the chain, --config DIR/run.json repeating a run bit for
// bit, and --sampler hmc through the same front end. Also `rbc stretch`'s continuum contact load
// and measure options, whose shapes these tests read the same way.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_run.hpp"
#include "continuum/surface_extent.hpp"
#include "core/h5file.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::fresh_output_dir;
using testing::run_rbc;

std::string quoted(const fs::path& p) {
  std::string q = "'";  // (appended: GCC 12's -Wrestrict misfires on "'" + string)
  q += p.string();
  q += '\'';
  return q;
}

json read_json(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

std::vector<double> read_dataset(const fs::path& file, const std::string& name) {
  std::vector<double> v;
  H5File::open_read(file.string()).read(name, v);
  return v;
}

/// `rbc mc -n 150 -q ARGS` is refused before any work: exit 2, one line on stderr.
void expect_refused_in_one_line(const std::string& args) {
  const CliRun b = run_rbc("mc -n 150 -q " + args);
  EXPECT_EQ(b.exit_code, 2) << args << "\n" << b.all();
  EXPECT_NE(b.err.find("rbc: error:"), std::string::npos) << b.all();
  EXPECT_EQ(std::count(b.err.begin(), b.err.end(), '\n'), 1) << b.all();
}

TEST(McCli, ThreadDecisionIsRecordedInJsonAndRunJson) {
  // Two threads available, N = 150: the sweeps run on one (a second does not pay at this size),
  // and both outputs say so with the reason.
  const fs::path dir = fresh_output_dir("mc_cli_threads");
  // One chain: its sweeps' own decision (several chains: tests/app/test_mc_chains_cli.cpp).
  const CliRun r = run_rbc(
      "mc -n 150 --force 20 --sweeps 40 --chains 1 -q --json --no-picture --out " + quoted(dir), 2);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const json printed = json::parse(r.out);
  const json manifest = read_json(dir / "run.json");
  const json summary = read_json(dir / "mc_summary.json");
  for (const json* j : {&printed, &manifest, &summary}) {
    ASSERT_TRUE(j->contains("threads")) << j->dump(2);
    const json& t = j->at("threads");
    EXPECT_EQ(t.at("used").get<int>(), 1) << t.dump();
    EXPECT_EQ(t.at("requested").get<int>(), 2) << t.dump();
    EXPECT_EQ(t.at("reason").get<std::string>().rfind("1: a second thread does not pay", 0), 0u)
        << t.dump();
  }
  // One thread available: that is the reason.
  const CliRun one = run_rbc("mc -n 150 --force 20 --sweeps 10 --chains 1 -q --json", 1);
  ASSERT_EQ(one.exit_code, 0) << one.all();
  EXPECT_EQ(json::parse(one.out).at("threads").at("reason"),
            "1: one thread requested (OMP_NUM_THREADS)");
}

TEST(McCli, ForceHasNoShortForm) {
  // -f is no command's short form for --force: refused with exit 2 before any work.
  const CliRun r = run_rbc("mc -n 150 -f 20 --sweeps 10 -q");
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("-f"), std::string::npos) << r.all();
  EXPECT_EQ(run_rbc("mc -n 150 --force 20 --sweeps 10 -q").exit_code, 0);
}

TEST(McCli, SnapshotDisplacementIsTheQuantityStretchShapesCallSo) {
  // From the rest shape, snapshot 0 holds X; the last one x. displacement_um must be |x - X|
  // per vertex (what the stretch shapes call displacement_um) and displacement_x_um x - X's
  // x component.
  const fs::path dir = fresh_output_dir("mc_cli_displacement");
  const CliRun r = run_rbc(
      "mc -n 150 --start rest --sweeps 30 --snapshot-every 30 -q "
      "--no-picture --out " +
      quoted(dir / "mc"));
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const fs::path first = dir / "mc" / "mc_snapshot_00000000.h5",
                 last = dir / "mc" / "mc_snapshot_00000030.h5";
  const std::vector<double> X = read_dataset(first, "/mesh/positions_um"),
                            x = read_dataset(last, "/mesh/positions_um"),
                            u = read_dataset(last, "/vertex/displacement_um"),
                            ux = read_dataset(last, "/vertex/displacement_x_um"),
                            u0 = read_dataset(first, "/vertex/displacement_um");
  ASSERT_EQ(X.size(), x.size());
  const std::size_t n = X.size() / 3;
  ASSERT_EQ(u.size(), n);
  ASSERT_EQ(ux.size(), n);
  EXPECT_EQ(*std::max_element(u0.begin(), u0.end()), 0.0);  // snapshot 0 is the rest shape
  double moved = 0, off_axis = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = x[3 * i] - X[3 * i], dy = x[3 * i + 1] - X[3 * i + 1],
                 dz = x[3 * i + 2] - X[3 * i + 2];
    EXPECT_NEAR(u[i], std::sqrt(dx * dx + dy * dy + dz * dz), 1e-12) << "vertex " << i;
    EXPECT_NEAR(ux[i], dx, 1e-12) << "vertex " << i;
    moved = std::max(moved, u[i]);
    off_axis = std::max(off_axis, u[i] - std::abs(ux[i]));
  }
  EXPECT_GT(moved, 0.0);     // the chain moved
  EXPECT_GT(off_axis, 0.0);  // and the two fields differ

  // The stretch shapes: the same field name for the same quantity, |x - X| from the same rest
  // shape.
  const CliRun s = run_rbc("stretch -n 150 --force 20 -q --out " + quoted(dir / "stretch"));
  ASSERT_EQ(s.exit_code, 0) << s.all();
  fs::path shape;
  for (const auto& e : fs::directory_iterator(dir / "stretch"))
    if (e.path().extension() == ".h5" && e.path().filename().string().rfind("shape_", 0) == 0)
      shape = e.path();
  ASSERT_FALSE(shape.empty());
  const std::vector<double> xs = read_dataset(shape, "/mesh/positions_um"),
                            us = read_dataset(shape, "/vertex/displacement_um");
  ASSERT_EQ(xs.size(), X.size());
  ASSERT_EQ(us.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = xs[3 * i] - X[3 * i], dy = xs[3 * i + 1] - X[3 * i + 1],
                 dz = xs[3 * i + 2] - X[3 * i + 2];
    EXPECT_NEAR(us[i], std::sqrt(dx * dx + dy * dy + dz * dz), 1e-9) << "vertex " << i;
  }
}

json mc_json(const std::string& args) {
  const CliRun r = run_rbc(args + " -q --json");
  EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.all();
  return r.exit_code == 0 ? json::parse(r.out) : json::object();
}

double stretch_axial_um(const std::string& args) {
  const CliRun r = run_rbc("stretch " + args + " -q --json");
  EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.all();
  return r.exit_code == 0 ? json::parse(r.out).at("points").at(0).at("axial_um").get<double>()
                          : 0.0;
}

TEST(McCli, LongerPersistenceLengthSoftensTheLinksAndStretchesTheCellFurther) {
  // WLC stiffness ~ k_B T/p: at p = 10 nm (default 7.5) the links are softer, so under 88 pN
  // the cell is longer, at zero temperature (the chain's start, which must be rbc stretch's
  // equilibrium) and in the chain's mean.
  const std::string run = "mc -n 150 --force 88 --sweeps 100";
  const json soft = mc_json(run + " --persistence 10"), stiff = mc_json(run);
  ASSERT_FALSE(soft.empty());
  ASSERT_FALSE(stiff.empty());
  EXPECT_EQ(soft.at("config").at("persistence").get<double>(), 10.0);
  const double soft0 = soft.at("reference_axial_um").get<double>(),
               stiff0 = stiff.at("reference_axial_um").get<double>();
  EXPECT_GT(soft0, stiff0 + 0.5);  // 13.2 against 12.1 um
  EXPECT_NEAR(soft0, stretch_axial_um("-n 150 --force 88 --persistence 10"), 1e-4);
  EXPECT_NEAR(stiff0, stretch_axial_um("-n 150 --force 88"), 1e-4);
  EXPECT_GT(soft.at("axial_um").at("mean").get<double>(),
            stiff.at("axial_um").at("mean").get<double>() + 0.5);
}

TEST(McCli, OneTemperatureSetsTheLinksAndTheChain) {
  const json both = mc_json("mc -n 150 --force 20 --sweeps 20 --temperature 310");
  ASSERT_FALSE(both.empty());
  EXPECT_EQ(both.at("temperature_K").get<double>(), 310.0);  // the chain's
  EXPECT_TRUE(both.at("config").at("sampling-temperature").is_null());
  // The chain at 300 K on links at 310 K: another network than the default (its zero-
  // temperature start differs), sampled at 300 K.
  const json split =
      mc_json("mc -n 150 --force 20 --sweeps 20 --temperature 310 --sampling-temperature 300");
  const json plain = mc_json("mc -n 150 --force 20 --sweeps 20");
  ASSERT_FALSE(split.empty());
  ASSERT_FALSE(plain.empty());
  EXPECT_EQ(split.at("temperature_K").get<double>(), 300.0);
  EXPECT_EQ(plain.at("temperature_K").get<double>(), 300.0);
  EXPECT_EQ(split.at("reference_axial_um"), both.at("reference_axial_um"));
  EXPECT_NE(split.at("reference_axial_um"), plain.at("reference_axial_um"));
  // -T is no short form any more (--temperature is the links' temperature in every command).
  EXPECT_EQ(run_rbc("mc -n 150 -T 300 --sweeps 1 -q").exit_code, 2);
  const CliRun bad = run_rbc("mc -n 150 --sampling-temperature -1 --sweeps 1 -q");
  EXPECT_EQ(bad.exit_code, 2) << bad.all();
  EXPECT_NE(bad.err.find("--sampling-temperature"), std::string::npos) << bad.all();
}

TEST(McCli, ConfigOfARunRepeatsItBitForBit) {
  // A run with non-default physics and options, then --config DIR/run.json into another
  // directory: the same chain, file for file, and the same record of threads.
  const fs::path dir = fresh_output_dir("mc_cli_config");
  const CliRun first = run_rbc(
      "mc -n 150 --force 20 --sweeps 60 --seed 5 --persistence 10 "
      "--temperature 310 --adapt-sweeps 10 -q --no-picture --out " +
          quoted(dir / "D"),
      2);
  ASSERT_EQ(first.exit_code, 0) << first.all();
  const CliRun again =
      run_rbc("mc --config " + quoted(dir / "D" / "run.json") + " --out " + quoted(dir / "E"), 2);
  ASSERT_EQ(again.exit_code, 0) << again.all();
  {  // the series as text, every digit written (not the comment lines: they record the run)
    auto data_lines = [](const fs::path& p) {
      std::ifstream in(p);
      std::string text;
      for (std::string line; std::getline(in, line);)
        if (line.rfind('#', 0) != 0) text += line + "\n";
      return text;
    };
    const std::string sa = data_lines(dir / "D" / "mc_series.csv"),
                      sb = data_lines(dir / "E" / "mc_series.csv");
    EXPECT_FALSE(sa.empty());
    EXPECT_TRUE(sa == sb) << "mc_series.csv differs";
  }
  {  // and as doubles (the HDF5 file itself holds a modification time)
    const std::vector<double> a = read_dataset(dir / "D" / "mc_series.h5", "/series"),
                              b = read_dataset(dir / "E" / "mc_series.h5", "/series");
    EXPECT_EQ(a.size(), 60u * 8u);
    EXPECT_TRUE(a == b) << "mc_series.h5 /series differs";
  }
  const json d = read_json(dir / "D" / "run.json"), e = read_json(dir / "E" / "run.json");
  json dc = d.at("config"), ec = e.at("config");
  EXPECT_EQ(ec.at("persistence").get<double>(), 10.0);
  EXPECT_EQ(ec.at("temperature").get<double>(), 310.0);
  dc.erase("out");
  ec.erase("out");
  EXPECT_EQ(dc, ec);
  EXPECT_EQ(d.at("threads"), e.at("threads"));
  EXPECT_EQ(e.at("threads").at("used").get<int>(), 2);  // two chains, one per thread
  EXPECT_TRUE(e.at("provenance").contains("command_line"));
  const json ds = read_json(dir / "D" / "mc_summary.json"),
             es = read_json(dir / "E" / "mc_summary.json");
  for (const char* k : {"axial_um", "transverse_um", "energy_pNum", "reference_axial_um"})
    EXPECT_EQ(ds.at(k), es.at(k)) << k;
  EXPECT_EQ(ds.at("temperature_K").get<double>(), 310.0);
}

TEST(McCli, ResumeRefusesACheckpointOfOtherPhysics) {
  // The chain is only valid on the energy it sampled: a checkpoint of p = 10 nm does not resume
  // on the default links, and resumes with the same --persistence.
  const fs::path dir = fresh_output_dir("mc_cli_resume_model");
  const std::string c = quoted(dir / "c.h5");
  ASSERT_EQ(run_rbc("mc -n 150 --sweeps 20 -q --persistence 10 --checkpoint " + c).exit_code, 0);
  const CliRun other = run_rbc("mc --sweeps 40 -q --resume " + c);
  EXPECT_EQ(other.exit_code, 2) << other.all();
  EXPECT_NE(other.err.find("another network"), std::string::npos) << other.all();
  EXPECT_EQ(run_rbc("mc --sweeps 40 -q --persistence 10 --resume " + c).exit_code, 0);
}

}  // namespace
}  // namespace rbc

namespace rbc {
namespace {

// --sampler hmc runs the collective chain through the same front end (JSON names the sampler;
// a checkpoint resumes it on another thread count bit for bit), and its refusals come before
// any work: an unknown sampler, a zero sampling temperature, a step outside (0, 4].
TEST(McCli, HmcSamplerRunsResumesAndRefusesBadInput) {
  using testing::fresh_output_dir;
  using testing::run_rbc;
  const fs::path dir = fresh_output_dir("mc_cli_hmc");
  const std::string base = "mc -n 150 --force 20 --sampler hmc --adapt-sweeps 4 --seed 2 -q --json";
  const CliRun whole = run_rbc(base + " --sweeps 20", 2);
  ASSERT_EQ(whole.exit_code, 0) << whole.all();
  const json w = json::parse(whole.out);
  EXPECT_EQ(w.at("sampler"), "hmc");
  EXPECT_EQ(w.at("sweeps"), 20);
  const std::string ck = quoted(dir / "chain.h5");
  ASSERT_EQ(run_rbc(base + " --sweeps 5 --checkpoint " + ck + " --checkpoint-every 5", 2).exit_code,
            0);
  const CliRun resumed = run_rbc("mc --resume " + ck + " --sweeps 20 -q --json", 1);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.all();
  const json r = json::parse(resumed.out);
  EXPECT_EQ(r.at("sampler"), "hmc");
  EXPECT_EQ(r.at("energy_pNum").at("mean"), w.at("energy_pNum").at("mean"));
  EXPECT_EQ(r.at("axial_um").at("mean"), w.at("axial_um").at("mean"));
  // A resumed checkpoint cannot change its sampler.
  const CliRun other = run_rbc("mc --resume " + ck + " --sampler metropolis --sweeps 10 -q");
  EXPECT_EQ(other.exit_code, 2) << other.all();
  EXPECT_NE(other.err.find("hmc"), std::string::npos) << other.all();
  for (const std::string bad : {"--sampler gibbs", "--sampler hmc --sampling-temperature 0",
                                "--sampler hmc --hmc-step 5", "--sampler hmc --hmc-step 0"})
    expect_refused_in_one_line("--sweeps 1 " + bad);
}

}  // namespace
}  // namespace rbc

namespace rbc {
namespace {

// --hmc-area-volume through the front end: exact by default, recorded in the JSON, the area and
// volume at A0 and V0 to 1e-10; a checkpoint resumes on another thread count to the straight
// run's means bit for bit; a resume that asks for the other mode (either way round), an unknown
// value, or the option on a Metropolis run, is refused in one line.
TEST(McCli, HmcAreaVolumeRecordsHoldsResumesAndRefusesBadInput) {
  using testing::fresh_output_dir;
  using testing::run_rbc;
  const fs::path dir = fresh_output_dir("mc_cli_hmc_exact");
  const std::string base =
      "mc -n 150 --force 20 --sampler hmc --adapt-sweeps 4 --seed 2 --chains 1 -q --json";
  const CliRun whole = run_rbc(base + " --sweeps 20", 2);
  ASSERT_EQ(whole.exit_code, 0) << whole.all();
  const json w = json::parse(whole.out);
  EXPECT_EQ(w.at("hmc").at("area_volume"), "exact");
  EXPECT_LE(w.at("max_area_drift").get<double>(), 1e-10);
  EXPECT_LE(w.at("max_volume_drift").get<double>(), 1e-10);
  const std::string ck = quoted(dir / "chain.h5");
  ASSERT_EQ(
      run_rbc(base + " --sweeps 10 --checkpoint " + ck + " --checkpoint-every 10", 2).exit_code, 0);
  const CliRun resumed = run_rbc("mc --resume " + ck + " --sweeps 20 -q --json", 1);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.all();
  const json r = json::parse(resumed.out);
  EXPECT_EQ(r.at("hmc").at("area_volume"), "exact");
  EXPECT_EQ(r.at("energy_pNum").at("mean"), w.at("energy_pNum").at("mean"));
  EXPECT_EQ(r.at("axial_um").at("mean"), w.at("axial_um").at("mean"));
  const CliRun other = run_rbc("mc --resume " + ck + " --hmc-area-volume penalty --sweeps 30 -q");
  EXPECT_EQ(other.exit_code, 2) << other.all();
  EXPECT_NE(other.err.find("--hmc-area-volume exact, not penalty"), std::string::npos)
      << other.all();
  const std::string penalty_ck = quoted(dir / "penalty.h5");
  const CliRun penalty = run_rbc(base + " --hmc-area-volume penalty --sweeps 10 --checkpoint " +
                                     penalty_ck + " --checkpoint-every 10",
                                 2);
  ASSERT_EQ(penalty.exit_code, 0) << penalty.all();
  EXPECT_EQ(json::parse(penalty.out).at("hmc").at("area_volume"), "penalty");
  const CliRun to_exact =
      run_rbc("mc --resume " + penalty_ck + " --hmc-area-volume exact --sweeps 30 -q");
  EXPECT_EQ(to_exact.exit_code, 2) << to_exact.all();
  EXPECT_NE(to_exact.err.find("--hmc-area-volume penalty, not exact"), std::string::npos)
      << to_exact.all();
  const CliRun penalty_on = run_rbc("mc --resume " + penalty_ck + " --sweeps 20 -q --json", 1);
  ASSERT_EQ(penalty_on.exit_code, 0) << penalty_on.all();
  EXPECT_EQ(json::parse(penalty_on.out).at("hmc").at("area_volume"), "penalty");
  expect_refused_in_one_line("--sweeps 1 --sampler hmc --hmc-area-volume hard");
  // An HMC option on a Metropolis run is refused, not ignored.
  for (const std::string hmc_only : {"--hmc-area-volume penalty", "--hmc-step 0.2"}) {
    expect_refused_in_one_line("--sweeps 1 " + hmc_only);
    const CliRun m = run_rbc("mc -n 150 -q --sweeps 1 --sampler metropolis " + hmc_only);
    EXPECT_NE(m.err.find(hmc_only.substr(0, hmc_only.find(' ')) +
                         ": an option of --sampler hmc, but the run uses --sampler metropolis"),
              std::string::npos)
        << m.all();
  }
  // So is one given to resume a Metropolis chain: the checkpoint fixes the sampler.
  const fs::path m_dir = fresh_output_dir("mc_cli_resume_metropolis_hmc_option");
  const std::string metropolis_ck = quoted(m_dir / "m.h5");
  ASSERT_EQ(run_rbc("mc -n 150 -q --sweeps 10 --checkpoint " + metropolis_ck).exit_code, 0);
  const CliRun hmc_option =
      run_rbc("mc --resume " + metropolis_ck + " --sweeps 20 -q --hmc-step 0.2");
  EXPECT_EQ(hmc_option.exit_code, 2) << hmc_option.all();
  EXPECT_NE(hmc_option.err.find("--hmc-step: an option of --sampler hmc, but the checkpoint"),
            std::string::npos)
      << hmc_option.all();
  EXPECT_NE(hmc_option.err.find("holds a chain of --sampler metropolis"), std::string::npos)
      << hmc_option.all();
}

// --hmc-mass-reference thermal through the front end: the JSON records the option and where the
// matrix in use was built; a checkpoint after the rebuild (adaptive sweeps 8, averaged over
// 4 .. 7; the library test HmcThermalMass.ResumesAcrossTheRebuildBitForBitOnAnyThreadCount
// checkpoints inside the window too) resumes on another thread count to the straight run's means
// bit for bit; too short an adaptive phase and an unknown reference are refused in one line
// before any work.
TEST(McCli, HmcThermalMassReferenceRecordsResumesAndRefusesBadInput) {
  using testing::fresh_output_dir;
  using testing::run_rbc;
  const fs::path dir = fresh_output_dir("mc_cli_hmc_thermal");
  const std::string base =
      "mc -n 150 --force 20 --sampler hmc --hmc-mass-reference thermal --adapt-sweeps 8 --seed 2 "
      "--chains 1 -q --json";
  const CliRun whole = run_rbc(base + " --sweeps 20", 2);
  ASSERT_EQ(whole.exit_code, 0) << whole.all();
  const json w = json::parse(whole.out);
  EXPECT_EQ(w.at("hmc").at("mass_reference"), "thermal");
  EXPECT_EQ(w.at("hmc").at("mass_built_at"), "thermal mean");
  EXPECT_EQ(w.at("hmc").at("mass_reference_transitions"), 4);
  const std::string ck = quoted(dir / "chain.h5");
  ASSERT_EQ(
      run_rbc(base + " --sweeps 10 --checkpoint " + ck + " --checkpoint-every 10", 2).exit_code, 0);
  const CliRun resumed = run_rbc("mc --resume " + ck + " --sweeps 20 -q --json", 1);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.all();
  const json r = json::parse(resumed.out);
  EXPECT_EQ(r.at("hmc").at("mass_built_at"), "thermal mean");
  EXPECT_EQ(r.at("energy_pNum").at("mean"), w.at("energy_pNum").at("mean"));
  EXPECT_EQ(r.at("axial_um").at("mean"), w.at("axial_um").at("mean"));
  const CliRun plain = run_rbc(
      "mc -n 150 --force 20 --sampler hmc --adapt-sweeps 8 --seed 2 "
      "--chains 1 -q --json --sweeps 20",
      2);
  ASSERT_EQ(plain.exit_code, 0) << plain.all();
  EXPECT_EQ(json::parse(plain.out).at("hmc").at("mass_built_at"), "start");
  for (const std::string bad : {"--sampler hmc --hmc-mass-reference thermal --adapt-sweeps 1",
                                "--sampler hmc --hmc-mass-reference hot"})
    expect_refused_in_one_line("--sweeps 10 " + bad);
}

}  // namespace
}  // namespace rbc

namespace rbc {
namespace {

// The continuum's exact contact load and quadric-fit measure through `rbc stretch`: the
// diameters printed are those of the quadric fit on the shape written (recomputed here from the
// file), the run differs from the default vertex patch and vertex measure, the shape carries the
// error indicator, whose largest values lie near the bead rims (|x| beyond 0.35 D_A), and the
// options are refused for the network.
TEST(StretchCli, ExactContactLoadAndQuadricMeasureReachTheContinuumRun) {
  const fs::path dir = fresh_output_dir("stretch_cli_contact_measure");
  const std::string base = "stretch --model continuum --elements 500 --force 193 -q --json";
  const CliRun r = run_rbc(base +
                               " --contact-load exact-contact --measure quadric-fit "
                               "--no-picture --out " +
                               quoted(dir / "s"),
                           2);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const json p = json::parse(r.out).at("points").at(0);
  const fs::path shape = dir / "s" / "shape_193.0pN.h5";
  const std::vector<double> xs = read_dataset(shape, "/mesh/positions_um");
  std::vector<int> fs_;
  H5File::open_read(shape.string()).read("/mesh/faces", fs_);
  const int n = static_cast<int>(xs.size() / 3);
  const Positions x = Eigen::Map<const Positions>(xs.data(), 3, n);
  const Faces faces = Eigen::Map<const Faces>(fs_.data(), 3, Eigen::Index(fs_.size() / 3));
  const Diameters d = surface_diameters(x, build_topology(faces, n));
  EXPECT_NEAR(p.at("axial_um").get<double>(), d.axial_um, 1e-9);
  EXPECT_NEAR(p.at("transverse_um").get<double>(), d.transverse_um, 1e-9);
  const CliRun plain = run_rbc(base, 2);
  ASSERT_EQ(plain.exit_code, 0) << plain.all();
  EXPECT_GT(
      std::abs(json::parse(plain.out).at("points").at(0).at("axial_um").get<double>() - d.axial_um),
      0.05);
  const std::vector<double> eta = read_dataset(shape, "/face/error_indicator_pN");
  ASSERT_EQ(static_cast<Eigen::Index>(eta.size()), faces.cols());
  const auto worst = std::max_element(eta.begin(), eta.end()) - eta.begin();
  double centroid_x = 0;
  for (int k = 0; k < 3; ++k) centroid_x += x(0, faces(k, worst)) / 3.0;
  EXPECT_GT(std::abs(centroid_x - x.row(0).mean()), 0.35 * d.axial_um);
  for (const std::string opt : {"--contact-load exact-contact", "--measure quadric-fit"}) {
    const CliRun bad = run_rbc("stretch --force 10 -q " + opt);
    EXPECT_EQ(bad.exit_code, 2) << bad.all();
    EXPECT_NE(bad.err.find("applies to --model continuum"), std::string::npos) << bad.all();
  }
}

}  // namespace
}  // namespace rbc
